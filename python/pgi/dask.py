"""pgi ensembles on a Dask cluster (Debian's python3-distributed): the same numbers, bit for bit, as
Scheme.integrate_ensemble on one machine.

    from distributed import Client
    import pgi, pgi.dask
    client = Client("tcp://scheduler:8786")          # or Client(LocalCluster(...))
    s = pgi.Scheme.from_toml("rigid_body.toml")
    r = pgi.dask.integrate_ensemble(client, s, X0, dt=0.1, t_end=100, chunks=1000)   # a pgi.EnsembleResult

X0 is split into chunks of rows; each task carries the scheme's description (its constructor's values, or
its scene's text), never a compiled object; each worker rebuilds a scheme once per description and keeps it
(the exact phase runs once per worker), and runs its chunks with the step built at the ensemble's x_typical,
chosen here from the whole X0, so each row's numbers do not depend on which worker ran it or with what.
Workers must run the same pgi build (the same compiled arithmetic) for the bit-for-bit promise to hold.
"""
import threading
import uuid
import warnings

import numpy as _np

from . import _parameter_values, EnergyWarning, EnsembleResult, InputError, _rebuild, _states, _warn_energy

__all__ = ["integrate_ensemble", "sweep"]

_FIELDS = ("x", "x_final", "energy_error", "casimir_error", "status", "steps", "failed_step", "failed_t", "residual",
           "newton_iterations_mean", "newton_iterations_max", "energy_warning")
# what a recording ensemble adds: per trajectory (gathered like _FIELDS), per crossing (event_row shifted by the
# chunk's first row), and the rows' times (every chunk's)
_RECORDED_ROWS = ("rows", "terminal_event", "jacobian")
_RECORDED_EVENTS = ("event_row", "event_index", "event_t", "event_x", "event_step")
_cache_lock = threading.Lock()


def _worker_scheme(description, dt):
    """The worker's Scheme for this description and dt, built on first use and kept on the worker. One per dt,
    so that a worker's scheme sees the dts of one run only, as the local run's does (its kept steps then stay
    those of the run)."""
    from distributed import get_worker
    worker = get_worker()
    key = (repr(description), dt)
    with _cache_lock:
        cache = worker.__dict__.setdefault("_pgi_schemes", {})
        if key not in cache:
            cache[key] = _rebuild(description)
        return cache[key]


def _run_chunk(description, X0, dt, t_end, x_typical, threads, limits=None, parameters=None, record=None):
    with warnings.catch_warnings():  # said once, on the client, for the whole ensemble
        warnings.simplefilter("ignore", EnergyWarning)
        r = _worker_scheme(description, dt).integrate_ensemble(X0, dt=dt, t_end=t_end, threads=threads, x_typical=x_typical,
                                                               parameters=parameters, **(limits or {}), **(record or {}))
    return {f: v for f, v in vars(r).items() if f in _FIELDS + _RECORDED_ROWS + _RECORDED_EVENTS}


def _gather(empty, parts, bounds):
    """The chunks' results (parts, of rows bounds[i]) as one ensemble's fields, in order (empty: the result on no
    rows, for the shapes)."""
    d = {f: _np.concatenate([getattr(empty, f)] + [p[f] for p in parts])
         for f in _FIELDS + _RECORDED_ROWS + _RECORDED_EVENTS if hasattr(empty, f)}
    if hasattr(empty, "event_row"):
        d["event_row"] = _np.concatenate([empty.event_row] + [p["event_row"] + a for p, (a, _) in zip(parts, bounds)])
    if hasattr(empty, "t"):
        d["t"] = empty.t
    return d


def _chunk_parameters(parameters, m):
    """parameters as integrate_ensemble checks them ({name: a number or one value per row of X0}), and a function of
    (a, b) giving rows a..b-1's (a number stays one)."""
    pairs = dict(_parameter_values(parameters))
    for k, v in pairs.items():
        if len(v) not in (1, m):
            raise InputError(f"parameters.{k}: has {len(v)} values, for {m} trajectories (give 1 value, or one per "
                             f"trajectory)")
    return lambda a, b: {k: (v if len(v) == 1 else v[a:b]) for k, v in pairs.items()} or None


class _Job:
    """One ensemble's chunks, submitted; collect() gathers them in order."""

    @staticmethod
    def check(scheme, X0, dt, t_end, max_steps, max_output_mb, parameters=None, record=None):
        """Every check of the local run (shape, dtype, dt, t_end, what is recorded, the budgets, the parameters), on
        no rows and then on all of them, before any work (a chunk is checked again on its worker, with its rows):
        X0, the empty result and the parameters' slicer."""
        X0 = _states(X0)
        limits = dict(max_steps=max_steps, max_output_mb=max_output_mb)
        rows = _chunk_parameters(parameters, len(X0))
        first = {k: v[:1] for k, v in (rows(0, len(X0)) or {}).items()}  # names and values checked on no rows
        empty = scheme.integrate_ensemble(X0[:0], dt=dt, t_end=t_end, threads=1, parameters=first or None, **limits,
                                          **(record or {}))
        scheme._check_ensemble(len(X0), dt=dt, t_end=t_end, **limits, **(record or {}))
        return X0, empty, rows

    def __init__(self, client, scheme, X0, dt, t_end, chunks, threads, retries, max_steps=None, max_output_mb=None,
                 parameters=None, record=None):
        X0, empty, rows = self.check(scheme, X0, dt, t_end, max_steps, max_output_mb, parameters, record)
        limits = dict(max_steps=max_steps, max_output_mb=max_output_mb)
        if chunks is not None and (isinstance(chunks, (bool, _np.bool_)) or not isinstance(chunks, (int, _np.integer))
                                   or chunks < 1):
            raise InputError(f"chunks: must be a positive number of rows, got {chunks!r}")
        self.m, self.dt, self.t_end, self.empty = len(X0), empty.dt, empty.t_end, empty
        self.x_typical = scheme.typical_state(X0)
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        size = int(chunks) if chunks else max(1, -(-self.m // (4 * workers)))
        self.bounds = [(a, min(a + size, self.m)) for a in range(0, self.m, size)]
        token = uuid.uuid4().hex
        self.futures = [client.submit(_run_chunk, scheme.description, _np.ascontiguousarray(X0[a:b]), self.dt,
                                      self.t_end, self.x_typical, threads, limits, rows(a, b), record,
                                      key=f"pgi-ensemble-{token}-{i}",
                                      retries=retries, pure=False)
                        for i, (a, b) in enumerate(self.bounds)]

    def collect(self):
        parts = []
        for i, (f, (a, b)) in enumerate(zip(self.futures, self.bounds)):
            try:
                parts.append(f.result())
            except Exception as e:
                for g in self.futures[i + 1:]:
                    g.cancel()
                raise RuntimeError(f"pgi.dask: chunk {i} (rows {a}..{b - 1} of X0) failed: {type(e).__name__}: {e}") from e
        d = _gather(self.empty, parts, self.bounds)
        d.update(x_typical=self.x_typical, threads=None, dt=self.dt, t_end=self.t_end, chunks=len(self.bounds))
        r = EnsembleResult(d)
        _warn_energy(int(r.energy_warning.sum()), len(r.energy_warning), r.dt)
        return r


def integrate_ensemble(client, scheme, X0, dt=None, t_end=None, chunks=None, threads=1, retries=2, max_steps=None,
                       max_output_mb=None, parameters=None, every=None, t_eval=None, events=None, event_samples=1,
                       tangent=False):
    """scheme.integrate_ensemble(X0, dt, t_end) on the client's cluster: chunks of `chunks` rows (default:
    about four chunks per worker), each run with `threads` threads on its worker, gathered in order; returns
    a pgi.EnsembleResult with the local run's numbers bit for bit. A chunk whose task raises is rerun
    `retries` times (Dask's own Client.submit(retries=)); a chunk whose worker dies is rerun elsewhere by the
    scheduler, up to its distributed.scheduler.allowed-failures deaths (default 3; retries does not count
    deaths). A chunk that still fails raises RuntimeError naming the chunk and its rows. Bad X0, dt or t_end
    raise ValueError, and a run above max_steps (steps per trajectory, default 1e8) or max_output_mb (the
    whole ensemble's results, default 1024) ResourceLimitError, before anything is submitted.

    parameters: as scheme.integrate_ensemble's ({name: a number, or one value per row of X0}), each chunk given its
    rows' values; with parameters, a chunk's step is built at its own rows' largest values, so the numbers equal the
    local run's to round-off (bit for bit without parameters).

    every, t_eval, events, event_samples, tangent: what each trajectory records, as scheme.integrate_ensemble's
    (x of shape (m, records, n), t, rows, x_final, event_row (rows of X0), ..., jacobian), gathered in order."""
    record = dict(every=every, t_eval=t_eval, events=events, event_samples=event_samples, tangent=tangent)
    return _Job(client, scheme, X0, dt, t_end, chunks, threads, retries, max_steps, max_output_mb,
                parameters, record).collect()


def sweep(client, runs, chunks=None, threads=1, retries=2, max_steps=None, max_output_mb=None):
    """Many ensembles at once (a parameter sweep over dt, order, a scene parameter, ...): runs is a list of
    dicts with the keys scheme, X0 and optionally dt, t_end, max_steps, max_output_mb (default: the
    arguments'); every run is checked before any is submitted, and every chunk of every run is submitted
    before any is gathered. Returns one pgi.EnsembleResult per run, in order, each equal to its own
    integrate_ensemble."""
    runs = list(runs)
    for r in runs:  # the whole sweep refused before any work
        _Job.check(r["scheme"], r["X0"], r.get("dt"), r.get("t_end"), r.get("max_steps", max_steps),
                   r.get("max_output_mb", max_output_mb))
    jobs = [_Job(client, r["scheme"], r["X0"], r.get("dt"), r.get("t_end"), chunks, threads, retries,
                 r.get("max_steps", max_steps), r.get("max_output_mb", max_output_mb)) for r in runs]
    return [j.collect() for j in jobs]
