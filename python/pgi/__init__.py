"""pgi: exact Poisson integrators from symplectic groupoids (Cosserat), from Python.

    import pgi
    s = pgi.Scheme(coordinates=["x1", "x2", "x3"],
                   brackets={"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"},
                   hamiltonian="x1^2/4 + x2^2/2 + 3*x3^2/4", casimirs=["x1^2 + x2^2 + x3^2"], order=4)
    s.check()                      # {'class': 'linear', 'jacobi': {'holds': True}, ...}
    s.terms()                      # exact S_1..S_k as strings (latex=True, or terms_sympy())
    s.step([0.6, 0.8, 0.3], 0.1)   # numpy array
    r = s.integrate([0.6, 0.8, 0.3], dt=0.1, t_end=100)   # r.t, r.x, r.energy_error, ...
    e = s.integrate_ensemble(X0, dt=0.1, t_end=100)       # X0: (m, 3) float64; e.x, e.status, ... on every core
    # pgi.dask.integrate_ensemble(client, s, X0, ...): the same, bit for bit, on a Dask cluster

"order" is k, the Hamilton-Jacobi truncation order; the method converges with order method_order = 2 ceil(k/2).
Bad input raises ValueError (pgi.InputError); a step not solved to round-off raises pgi.StepFailure.
"""
import warnings as _warnings

import numpy as _np

from ._pgi import InputError, NativeCodeError, ResourceLimitError, SceneError, __version__
from ._pgi import Scheme as _Scheme

__all__ = ["Scheme", "Result", "EnsembleResult", "StepFailure", "EnergyWarning", "InputError", "SceneError", "ResourceLimitError", "NativeCodeError",
           "__version__"]


class EnergyWarning(UserWarning):
    """A run (or some trajectories of an ensemble) whose relative energy error exceeded 0.1: every step solved its
    equation to round-off, but at this dt the method no longer follows the flow of H (as `pgi integrate` warns)."""


def _warn_energy(count, of, dt):
    if count:
        what = "the run" if of is None else f"{count} of {of} trajectories"
        _warnings.warn(f"{what} reached a relative energy error above 0.1 (energy_warning): every step solved its equation, "
                       f"but at dt = {dt} the method does not follow the flow of H (reduce dt or raise the order)",
                       EnergyWarning, stacklevel=3)


class StepFailure(ArithmeticError):
    """A step that was not solved to round-off (or left a non-finite state): step (1-based), t (where it
    started), residual, and result (the run up to the failure, for integrate)."""

    def __init__(self, message, step, t, residual, result=None):
        super().__init__(message)
        self.step, self.t, self.residual, self.result = step, t, residual, result


class Result:
    """A run: t (times recorded), x (one row per time), energy_error and casimir_error (relative, per row),
    their maxima over every step, energy_warning (energy_error_max above 0.1, or NaN: every step solved its
    equation, but at this dt the method no longer follows the flow of H), steps, dt, newton_iterations_mean/max,
    status ("ok", "terminal_event" or why it stopped). With events: event_index (which event, its place in the list), event_t, event_x (one
    row per crossing) and event_step (the step that holds it), in time order."""

    def __init__(self, d):
        self.__dict__.update(d)

    def __repr__(self):
        return (f"pgi.Result(steps={self.steps}, t_end={self.t[-1] if len(self.t) else 0.0}, status={self.status!r}, "
                f"energy_error_max={self.energy_error_max:.3e})")


class EnsembleResult:
    """An ensemble: per trajectory (one row of X0) x (m, n: the final state, or the last reached before a
    failure, or the row itself if it was not finite), energy_error (m,) and casimir_error (m, c) (the largest
    relative errors over every step; NaN for a row that was not finite), status ((m,) strings: "ok",
    "newton_not_converged", "non_finite", "non_finite_start"), steps, failed_step (1-based, 0 if none),
    failed_t, residual, newton_iterations_mean, newton_iterations_max, energy_warning ((m,) bool: energy_error above
    0.1, as for one run; never for a row that was not finite); and x_typical (the state the step was
    built for), threads, dt, t_end."""

    def __init__(self, d):
        self.__dict__.update(d)
        self.status = _np.array(self.status, dtype=str)

    @property
    def ok(self):
        """(m,) bool: the trajectories that reached t_end."""
        return self.status == "ok"

    def __repr__(self):
        return f"pgi.EnsembleResult(trajectories={len(self.status)}, ok={int(self.ok.sum())}, threads={self.threads})"


def _rebuild(description):
    """A Scheme from its description (what pickle carries): ("values", kwargs) or ("toml", text, file,
    trust_jacobi)."""
    if description[0] == "values":
        return Scheme(**description[1])
    return Scheme._from_toml_text(*description[1:])


def _flag(name, v):
    """v if it is a bool (numpy's included), else InputError: a flag given as 1 or "yes" is refused, not guessed."""
    if isinstance(v, (bool, _np.bool_)):
        return bool(v)
    raise InputError(f"{name}: must be True or False, got {v!r}")


_EVENT_KEYS = ("g", "direction", "terminal")


def _event(i, e):
    """Event i as (g, direction, terminal), from "g", a tuple (g[, direction[, terminal]]) or a dict with the
    keys g, direction (default 0), terminal (default False)."""
    where = f"events[{i}]"
    if isinstance(e, str):
        e = (e,)
    if isinstance(e, dict):
        unknown = sorted(set(e) - set(_EVENT_KEYS))
        if unknown or "g" not in e:
            raise InputError(f"{where}: a dict needs the key 'g' and may have 'direction' and 'terminal'"
                             + (f", not {unknown}" if unknown else ""))
        e = (e["g"], e.get("direction", 0), e.get("terminal", False))
    if not isinstance(e, (tuple, list)) or not 1 <= len(e) <= 3:
        raise InputError(f"{where}: must be a polynomial string, a tuple (g, direction, terminal) or a dict, got {e!r}")
    g, direction, terminal = tuple(e) + (None, 0, False)[len(e):]
    if not isinstance(g, str):
        raise InputError(f"{where}: g must be a polynomial string, got {g!r}")
    if isinstance(direction, bool) or not isinstance(direction, (int, _np.integer)) or direction not in (-1, 0, 1):
        raise InputError(f"{where}: direction must be -1, 0 or 1, got {direction!r}")
    if not isinstance(terminal, (bool, _np.bool_)):
        raise InputError(f"{where}: terminal must be True or False, got {terminal!r}")
    return g, int(direction), bool(terminal)


def _states(X0):
    """X0 as a numpy array: given as one, or converted from nested lists (a ragged or non-numeric list is an
    InputError naming X0; shape and dtype are checked by the C++ side)."""
    if isinstance(X0, _np.ndarray):
        return X0
    try:
        return _np.array(X0, dtype=float)
    except (TypeError, ValueError) as e:
        raise InputError(f"X0: must be an (m, n) array of numbers: {e}") from None


def _sympy(texts, coordinates):
    import sympy  # optional: only these conversions need it
    symbols = {c: sympy.Symbol(c) for c in coordinates}
    return [sympy.sympify(t.replace("^", "**"), locals=symbols) for t in texts]


class Scheme:
    """A Poisson integrator of order k for H on (R^n, pi), everything exact computed once, when first asked.

    Scheme(coordinates, brackets, hamiltonian, casimirs=[], order=2, realisation="auto", dt=None, x0=None,
    t_end=None) or Scheme.from_toml(path) (a pgi scene: its dt, x0 and t_end become the defaults).
    Attributes: coordinates, order (k), method_order, realisation, structure_class, hamiltonian, casimirs,
    dt, x0, t_end, name. Methods: check(), require_valid(), terms(latex=False), terms_sympy(),
    modified_hamiltonian(upto=4, latex=False), modified_hamiltonian_sympy(upto=4), realisation_terms(degree),
    step(x, dt=None), integrate(x0=None, dt=None, t_end=None, every=1)."""

    def __init__(self, coordinates, brackets, hamiltonian, casimirs=(), order=2, realisation="auto", dt=None,
                 x0=None, t_end=None, max_terms=20_000_000, trust_jacobi=False, jit=False):
        """trust_jacobi=True: the caller vouches for the Jacobi identity of the brackets, which is then not checked
        (check()["jacobi"] is then {"holds": None, "skipped": "trust_jacobi"}, as `pgi --trust-jacobi` reports it): for large structures known to be Poisson.
        jit=True: the steps' compiled maps become native code built by the system C++ compiler (as `pgi --jit`): the
        same numbers bit for bit, faster steps, 0.1-0.5 s more at the first build (kept in ~/.cache/pgi/jit);
        NativeCodeError if it cannot be built. A scene file says it as `jit = true` under [integrator]."""
        if x0 is not None:
            x0 = _np.asarray(x0, dtype=float)
        self._core = _Scheme(list(coordinates), dict(brackets), hamiltonian, list(casimirs), order, realisation, dt, x0,
                             t_end, max_terms, _flag("trust_jacobi", trust_jacobi), _flag("jit", jit))
        self._description = ("values", dict(coordinates=list(coordinates), brackets=dict(brackets),
                                            hamiltonian=hamiltonian, casimirs=list(casimirs), order=order,
                                            realisation=realisation, dt=dt, x0=None if x0 is None else x0.tolist(),
                                            t_end=t_end, max_terms=max_terms, trust_jacobi=trust_jacobi, jit=jit))

    @classmethod
    def from_toml(cls, path, trust_jacobi=False):
        """The scene file's scheme; trust_jacobi as for Scheme()."""
        trust_jacobi = _flag("trust_jacobi", trust_jacobi)
        try:  # the text, so a pickled Scheme carries the scene itself
            with open(path, "rb") as f:
                text = f.read()
        except OSError:
            _Scheme.from_toml(str(path), trust_jacobi)  # raises pgi's own SceneError naming the file
            raise
        return cls._from_toml_text(text, str(path), trust_jacobi)

    @classmethod
    def _from_toml_text(cls, text, file, trust_jacobi=False):
        s = cls.__new__(cls)
        s._core = _Scheme.from_toml_text(text, file, trust_jacobi)
        s._description = ("toml", text, file, trust_jacobi)
        return s

    @property
    def description(self):
        """What rebuilds this Scheme elsewhere: ("values", the constructor's arguments) or ("toml", the scene's
        text, its file name). Pickling a Scheme sends this; the exact work is redone (once) where it lands."""
        return self._description

    def __reduce__(self):
        return (_rebuild, (self._description,))

    def __getattr__(self, name):  # the C++ scheme's attributes and exact methods
        if name.startswith("__") or name == "_core":
            raise AttributeError(name)
        return getattr(self._core, name)

    def terms_sympy(self):
        """S_1..S_k as sympy expressions (needs sympy)."""
        return _sympy(self._core.terms(), self._core.coordinates)

    def modified_hamiltonian_sympy(self, upto=4):
        """H_0..H_upto as sympy expressions (needs sympy)."""
        return _sympy(self._core.modified_hamiltonian(upto), self._core.coordinates)

    def step(self, x, dt=None):
        """One step of size dt (default: the scheme's) from x: the new state as a numpy array. The compiled
        step for a dt is built once, sized at the scheme's x0 or else at the first x stepped with that dt."""
        r = self._core._step(_np.asarray(x, dtype=float), dt)
        if not r["ok"]:
            raise StepFailure(r["message"], 1, 0.0, r["residual"])
        return r["x"]

    def integrate(self, x0=None, dt=None, t_end=None, every=1, x_typical=None, events=None, event_samples=1):
        """ceil(t_end/dt) steps from x0 (defaults: the scheme's), Kahan-summed, recording every `every`-th
        state and the last; returns a Result. The GIL is released while it runs. Raises StepFailure (with
        .result holding the run up to the failure) if a step fails. The compiled step is built at x0, or at
        x_typical when given (an ensemble's x_typical gives its run of this trajectory, bit for bit).

        events: a list of polynomials g(x) in the coordinates whose zeros are reported, each "g", a tuple
        (g, direction, terminal) (direction +1: g rising through 0, -1: falling, 0: both, the default;
        terminal: the run stops at its first crossing, default False) or a dict with those keys. Crossings
        are located to round-off on the step's dense output (the method's order) and returned as
        r.event_index, r.event_t, r.event_x, r.event_step; a terminal crossing is the run's last row and
        r.status is "terminal_event". event_samples > 1 also tests that many - 1 interior points of each
        step (two crossings inside one step). A bad event raises ValueError naming it (events[i]) and,
        for a polynomial, the problem and its position."""
        if events is None:
            events = []
        elif isinstance(events, (str, dict)) or not isinstance(events, (list, tuple)):
            raise InputError(f"events: must be a list of events, got {events!r}")
        specs = [_event(i, e) for i, e in enumerate(events)]
        if isinstance(event_samples, bool) or not isinstance(event_samples, (int, _np.integer)) or event_samples < 1:
            raise InputError(f"event_samples: must be a positive integer, got {event_samples!r}")
        r = Result(self._core._integrate(None if x0 is None else _np.asarray(x0, dtype=float), dt, t_end, every,
                                         None if x_typical is None else _np.asarray(x_typical, dtype=float),
                                         specs, event_samples))
        if r.status not in ("ok", "terminal_event"):
            raise StepFailure(r.message, r.failed_step, r.failed_t, r.residual, r)
        _warn_energy(int(r.energy_warning), None, r.dt)
        return r

    def integrate_ensemble(self, X0, dt=None, t_end=None, threads=None, chunk=None, x_typical=None, batch=None):
        """Every row of X0 (an (m, n) float64 numpy array; nested lists are converted) over ceil(t_end/dt)
        steps, on `threads` cores (default: all), the GIL released; returns an EnsembleResult. Each row's
        numbers equal integrate(row, dt, t_end, x_typical=result.x_typical) bit for bit, whatever threads and
        chunk (trajectories per task) and batch (trajectories stepped together, structure of arrays; 1: one
        at a time; default 16 below 40 coordinates, else 1). The step is built once, at x_typical (default: the finite row of largest
        norm). A row that is not finite or a step that fails ends that trajectory with its status; nothing is
        raised for it. Raises ValueError (before any work) for X0 of the wrong shape or dtype."""
        X0 = _states(X0)
        for name, v in (("threads", threads), ("chunk", chunk), ("batch", batch)):
            if v is not None and (isinstance(v, (bool, _np.bool_)) or not isinstance(v, (int, _np.integer)) or v < 1):
                raise InputError(f"{name}: must be a positive integer, got {v!r}")
        r = EnsembleResult(self._core._integrate_ensemble(
            X0, dt, t_end, threads or 0, chunk or 0, None if x_typical is None else _np.asarray(x_typical, dtype=float),
            batch or 0))
        _warn_energy(int(r.energy_warning.sum()), len(r.energy_warning), r.dt)
        return r

    def typical_state(self, X0):
        """The row integrate_ensemble builds its step at by default: the finite row of largest norm (None if none)."""
        return self._core._typical_state(_states(X0))

    def __repr__(self):
        c = self._core
        return f"pgi.Scheme(coordinates={c.coordinates}, order={c.order}, realisation={c.realisation!r}, class={c.structure_class!r})"
