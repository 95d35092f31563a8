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
import collections.abc as _abc
import math as _math
import numbers as _numbers
import os as _os
import stat as _stat
import warnings as _warnings

import numpy as _np

from ._pgi import InputError, NativeCodeError, ResourceLimitError, SceneError, __version__
from ._pgi import Scheme as _Scheme
from ._pgi import _Recording
from ._pgi import max_scene_bytes as _max_scene_bytes

__all__ = ["Scheme", "Result", "EnsembleResult", "LyapunovResult", "StepFailure", "EnergyWarning", "InputError", "SceneError", "ResourceLimitError", "NativeCodeError",
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
    their maxima over every step, casimir_drift_per_step (per Casimir, the least-squares slope of its signed
    relative error per step: a bias, which a round-off random walk has not), energy_warning (energy_error_max above 0.1, or NaN: every step solved its
    equation, but at this dt the method no longer follows the flow of H), steps, dt, newton_iterations_mean/max,
    status ("ok", "terminal_event" or why it stopped, in the ensemble's words: "newton_not_converged",
    "non_finite", "truncation_above_bound", "ill_conditioned"; the message says it in full). With events: event_index (which event, its place in the list), event_t, event_x (one
    row per crossing) and event_step (the step that holds it), in time order."""

    def __init__(self, d):
        self.__dict__.update(d)

    def __repr__(self):
        return (f"pgi.Result(steps={self.steps}, t_end={self.t[-1] if len(self.t) else 0.0}, status={self.status!r}, "
                f"energy_error_max={self.energy_error_max:.3e})")


class LyapunovResult:
    """Lyapunov exponents (Scheme.lyapunov), in 1/time units: t (rows,) the recorded times, exponents (rows, n) the
    running estimates there, spectrum (n,) the last row. The first leaf_dim columns are the exponents on the
    symplectic leaf (Benettin's order: decreasing, in (+l, -l) pairs); the last n - leaf_dim (one per Casimir, across
    the leaf) are exactly 0. steps, dt, status (as Result.status)."""

    def __init__(self, d):
        self.__dict__.update(d)

    def __repr__(self):
        return f"pgi.LyapunovResult(steps={self.steps}, spectrum={self.spectrum.tolist()}, status={self.status!r})"


class EnsembleResult:
    """An ensemble: per trajectory (one row of X0) x (m, n: the final state, or the last reached before a
    failure, or the row itself if it was not finite), energy_error (m,) and casimir_error (m, c) (the largest
    relative errors over every step; NaN for a row that was not finite), status ((m,) strings: "ok",
    "newton_not_converged", "non_finite", "truncation_above_bound", "ill_conditioned" (as its single run's
    Result.status), "non_finite_start"), steps, failed_step (1-based, 0 if none),
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
    trust_jacobi, jit, max_seconds, max_memory_mb, max_terms), checked as the constructors check their arguments."""
    if description[0] == "values":
        return Scheme(**description[1])
    return Scheme._from_toml_text(*description[1:])


# The arguments' checks, one helper per kind of argument, used by every method: a mistake is an InputError
# (a ValueError) naming the argument, before any work, with the command line's ranges.
_MAX_COUNT = 2 ** 53  # the command line's largest whole number (--every, --max-steps, --max-terms)
_MAX_ORDER, _MAX_UPTO, _MAX_DEGREE = 64, 64, 100  # --order, --upto, --degree


def _shown(value):
    """repr(value) for a message, at most about 80 characters (a huge number or string is not echoed whole)."""
    r = repr(value)
    return r if len(r) <= 80 else f"{r[:60]}... ({len(r)} characters)"


def _events(events):
    """events as integrate and integrate_ensemble take them (None, or a list of "g", (g, direction, terminal) or
    dicts), normalised to (g, direction, terminal) tuples; else InputError naming events or events[i]."""
    if events is None:
        return []
    if isinstance(events, (str, dict)) or not isinstance(events, (list, tuple)):
        raise InputError(f"events: must be a list of events, got {_shown(events)}")
    return [_event(i, e) for i, e in enumerate(events)]


def _recording(every, t_eval, events, event_samples, tangent):
    """What each trajectory of an ensemble records, checked: every (None: no rows), t_eval, events, tangent."""
    return _Recording(every=0 if every is None else _count("every", every, 1, _MAX_COUNT),
                      t_eval=_times("t_eval", t_eval), events=_events(events),
                      event_samples=_count("event_samples", event_samples, 1, _MAX_COUNT),
                      tangent=_flag("tangent", tangent))


def _flag(name, v):
    """v if it is a bool (numpy's included), else InputError: a flag given as 1 or "yes" is refused, not guessed."""
    if isinstance(v, (bool, _np.bool_)):
        return bool(v)
    raise InputError(f"{name}: must be True or False, got {_shown(v)}")


def _jit(v):
    """jit as given if None, True or False (numpy's bool included), else InputError."""
    return None if v is None else _flag("jit", v)


def _real(name, value):
    """value as a float: a real number (int, float, Fraction, numpy's), not a bool, a string or a complex."""
    if isinstance(value, (bool, _np.bool_)) or not isinstance(value, _numbers.Real):
        raise InputError(f"{name}: must be a number, got {_shown(value)}")
    try:
        return float(value)
    except (OverflowError, ValueError) as e:
        raise InputError(f"{name}: must be a finite number, got {_shown(value)} ({e})") from None


def _positive_float(name, value, hi=_math.inf):
    """value (a real number) as a float with 0 < value <= hi, finite; None stays None (the default)."""
    if value is None:
        return None
    v = _real(name, value)
    if not (0 < v <= hi) or not _math.isfinite(v):
        raise InputError(f"{name}: must be positive and finite{'' if hi == _math.inf else f' and at most {hi:g}'}, got {_shown(value)}")
    return v


def _nonnegative_float(name, value):
    """value (a real number) as a finite float >= 0; None stays None (the default)."""
    if value is None:
        return None
    v = _real(name, value)
    if not (v >= 0) or not _math.isfinite(v):
        raise InputError(f"{name}: must be finite and not negative, got {_shown(value)}")
    return v


def _count(name, value, lo, hi):
    """value as an int with lo <= value <= hi: a whole number (int or numpy integer), not a bool nor a float."""
    if (isinstance(value, (bool, _np.bool_)) or not isinstance(value, _numbers.Integral)
            or not lo <= value <= hi):
        raise InputError(f"{name}: {_shown(value)} is not a whole number from {lo} to {'2^53' if hi == _MAX_COUNT else hi}")
    return int(value)


def _exact_budget(max_seconds, max_memory_mb):
    """The exact phase's time and memory budgets, checked with the command line's ranges (--max-seconds,
    --max-memory-mb); None stays None (no time limit; the default memory budget)."""
    return (_positive_float("max_seconds", max_seconds, 1e9),
            _optional_count("max_memory_mb", max_memory_mb, 1, 2 ** 40))


def _toml_arguments(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms):
    """Scheme.from_toml's keywords after the path, checked (a pickled description's too)."""
    return (_flag("trust_jacobi", trust_jacobi), _jit(jit), *_exact_budget(max_seconds, max_memory_mb),
            _count("max_terms", max_terms, 1, _MAX_COUNT))


def _toml_core_arguments(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms):
    """The checked keywords as the module takes them (no memory budget: 0)."""
    return trust_jacobi, jit, max_seconds, max_memory_mb or 0, max_terms


def _optional_count(name, value, lo, hi):
    return None if value is None else _count(name, value, lo, hi)


def _real_array(name, value, what):
    """value as a float64 numpy array; complex, boolean and non-numeric values are refused naming `name` (a
    complex number's imaginary part is never dropped). what describes what is expected, for the messages."""
    if isinstance(value, (str, bytes)):
        raise InputError(f"{name}: must be {what}, got a string {_shown(value)}")
    try:
        a = _np.asarray(value)
    except (TypeError, ValueError) as e:
        raise InputError(f"{name}: must be {what}: {e}") from None
    if a.dtype.kind == "c":
        raise InputError(f"{name}: complex values are not states (the imaginary part would be lost); pass real numbers")
    if a.dtype.kind not in "iufO":
        raise InputError(f"{name}: must be {what}, got dtype {a.dtype}")
    try:
        return a if a.dtype == _np.float64 else a.astype(_np.float64)
    except (TypeError, ValueError, OverflowError) as e:
        raise InputError(f"{name}: must be {what} (real): {e}") from None


def _state(name, value, n):
    """value as a state: n finite real numbers (a float64 vector); None stays None."""
    if value is None:
        return None
    a = _real_array(name, value, f"a vector of {n} numbers")
    if a.ndim != 1 or len(a) != n:
        got = f"{len(a)}" if a.ndim == 1 else f"an array of shape {a.shape}"
        raise InputError(f"{name}: must have {n} values (one per coordinate, a vector), got {got}")
    if not _np.isfinite(a).all():
        raise InputError(f"{name}: must be finite, got {a.tolist()}")
    return a


def _times(name, value):
    """value as requested output times: a 1-d float64 array (None stays None); their domain (finite, strictly
    increasing, within [0, t_end]) is checked by the run's plan, as for every surface."""
    if value is None:
        return None
    a = _real_array(name, value, "a 1-d array of times")
    if a.ndim != 1:
        raise InputError(f"{name}: must be a 1-d array of times, got an array of shape {a.shape}")
    if a.size == 0:  # (the run would record by steps instead, as without t_eval: never silently)
        raise InputError(f"{name}: is empty: give at least one time, or None to record by steps")
    return _np.ascontiguousarray(a)


def _states(X0, name="X0"):
    """X0 as a numpy array: a numpy array as given (not copied; shape and dtype, float64 only, are checked by
    the C++ side), or converted from nested lists. Complex values, a ragged or non-numeric list are an InputError
    naming the argument (name)."""
    if isinstance(X0, _np.ndarray):  # complex128 included: refused by its dtype, never converted
        return X0
    return _real_array(name, X0, "an (m, n) array of numbers")


def _polynomial(name, text):
    """text if it is a polynomial string; '**' (Python's power) gets the hint to write '^'."""
    if not isinstance(text, str):
        raise InputError(f"{name}: must be a polynomial string, got {_shown(text)}")
    if "**" in text:
        raise InputError(f"{name}: '**' is not a power in pgi: write x^2 (with ^) for x squared, got {_shown(text)}")
    return text


def _strings(name, value, what):
    """value as a list of strings; one string alone is refused with the hint to pass a list."""
    if isinstance(value, (str, bytes)):
        raise InputError(f"{name}: must be a list of {what}, got one string {_shown(value)}: pass a list, like [{_shown(value)}]")
    try:
        items = list(value)
    except TypeError:
        raise InputError(f"{name}: must be a list of {what}, got {_shown(value)}") from None
    for i, v in enumerate(items):
        if not isinstance(v, str):
            raise InputError(f"{name}[{i}]: must be a string, got {_shown(v)}")
    return items


def _parameter_defaults(value):
    """A scheme's parameters {name: exact value} as (name, text) pairs: a string ("2", "-1/3", "0.05", read exactly:
    0.05 is 1/20), an int, or a float (read as its shortest repr: 0.05 is 1/20)."""
    if value is None:
        return []
    if not isinstance(value, _abc.Mapping):
        raise InputError(f"parameters: must be a dict like {{\"w1\": \"1/2\"}}, got {_shown(value)}")
    pairs = []
    for k, v in value.items():
        if not isinstance(k, str):
            raise InputError(f"parameters: names must be strings, got {_shown(k)}")
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            raise InputError(f"parameters.{k}: must be an exact value as a string (\"2\", \"-1/3\", \"0.05\") or a "
                             f"number, got {_shown(v)}")
        pairs.append((k, v if isinstance(v, str) else repr(v)))
    return pairs


def _parameter_values(value):
    """A run's parameter values {name: value}, each a number or a 1-D array of numbers (one per trajectory or row),
    as (name, float64 vector) pairs; the scheme checks the names, the lengths and finiteness."""
    if value is None:
        return []
    if not isinstance(value, _abc.Mapping):
        raise InputError(f"parameters: must be a dict like {{\"w1\": 0.4}}, got {_shown(value)}")
    pairs = []
    for k, v in value.items():
        if not isinstance(k, str):
            raise InputError(f"parameters: names must be strings, got {_shown(k)}")
        a = _real_array(f"parameters.{k}", v, "a number or a 1-D array of numbers")
        if a.ndim > 1:
            raise InputError(f"parameters.{k}: must be a number or a 1-D array of numbers, got shape {a.shape}")
        pairs.append((k, _np.atleast_1d(a)))
    return pairs


def _limits(max_steps, max_output_mb):
    """The run's budgets (None: the library's defaults, 1e8 steps and 1024 MB kept in memory)."""
    return dict(max_steps=_optional_count("max_steps", max_steps, 1, _MAX_COUNT),
                max_output_mb=_positive_float("max_output_mb", max_output_mb, 1e9))


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
        raise InputError(f"{where}: must be a polynomial string, a tuple (g, direction, terminal) or a dict, got {_shown(e)}")
    g, direction, terminal = tuple(e) + (None, 0, False)[len(e):]
    if not isinstance(g, str):
        raise InputError(f"{where}: g must be a polynomial string, got {_shown(g)}")
    _polynomial(where, g)
    if isinstance(direction, bool) or not isinstance(direction, (int, _np.integer)) or direction not in (-1, 0, 1):
        raise InputError(f"{where}: direction must be -1, 0 or 1, got {_shown(direction)}")
    if not isinstance(terminal, (bool, _np.bool_)):
        raise InputError(f"{where}: terminal must be True or False, got {_shown(terminal)}")
    return g, int(direction), bool(terminal)


def _sympy(texts, coordinates):
    import sympy  # optional: only these conversions need it
    symbols = {c: sympy.Symbol(c) for c in coordinates}
    return [sympy.sympify(t.replace("^", "**"), locals=symbols) for t in texts]


class Scheme:
    """A Poisson integrator of order k for H on (R^n, pi), everything exact computed once, when first asked.

    Scheme(coordinates, brackets, hamiltonian, casimirs=[], order=2, realisation="auto", dt=None, x0=None,
    t_end=None) or Scheme.from_toml(path) (a pgi scene: its dt, x0 and t_end become the defaults).
    Properties: coordinates, order (k), method_order, realisation, structure_class, hamiltonian, casimirs,
    dt, x0, t_end, name, jacobi_trusted, jit. Methods: check(), require_valid(), terms(), modified_hamiltonian(),
    realisation_terms(), step(), integrate(), integrate_ensemble(), typical_state(), stats(), the sympy conversions
    and the numeric evaluators vector_field(), poisson_matrix(), hamiltonian_value(), casimir_values(),
    modified_hamiltonian_value().

    Polynomials are strings in the coordinates with +, -, *, / by numbers and ^ for powers ("x1^2/4 + x2*x3").
    A scheme whose brackets fail the Jacobi identity, or a Casimir that does not commute with every
    coordinate, is refused as the command line refuses it: terms(), modified_hamiltonian(), step(),
    integrate() and integrate_ensemble() raise InputError naming the failing triple and its jacobiator (or
    the Casimir), unless trust_jacobi=True. Every argument is checked before any work: a wrong type or a value
    out of range raises InputError (a ValueError) naming the argument."""

    def __init__(self, coordinates, brackets, hamiltonian, casimirs=(), order=2, realisation="auto", dt=None,
                 x0=None, t_end=None, max_terms=20_000_000, trust_jacobi=False, jit=None, parameters=None,
                 max_seconds=60, max_memory_mb=None):
        """coordinates: the names (a list of strings); brackets: {"a,b": "{a,b} as a polynomial"}, the others
        following by skew-symmetry; hamiltonian: H; casimirs: a list of polynomials that Poisson-commute with
        everything; order: k, 1..64; realisation: "auto", "closed-form" or "radial" (as a scene's);
        dt, x0, t_end: the defaults of step() and integrate().

        The exact phase's budget, as the command line's: max_terms bounds every product's terms (--max-terms),
        max_seconds the busy time of its algebra in each call that does exact work (--max-seconds; 60 as pgi's,
        None: no limit; the time between calls never counts), max_memory_mb the process's resident memory while it
        runs (--max-memory-mb; None: half the physical memory, or 3/4 of `ulimit -v`'s address space when one is
        set). Past one, the work stops with ResourceLimitError naming the limit; nothing is kept half-built. One
        product or power is checked before it starts (its predicted terms and memory) and after it ends (the time).

        trust_jacobi=True: the caller vouches for the Jacobi identity of the brackets, which is then not checked
        (check()["jacobi"] is then {"holds": None, "skipped": "trust_jacobi"}, as `pgi --trust-jacobi` reports it): for large structures known to be Poisson.
        jit: when the steps' compiled maps become native code from the system C++ compiler (the same numbers bit for
        bit, faster steps). None (the default): native code kept in ~/.cache/pgi/jit is used at once, and a long run
        builds it in the background after its first seconds and switches to it; True: built before the first step
        (as `pgi --jit`; NativeCodeError if it cannot be); False: never (`pgi --no-jit`). A scene file says
        `jit = true` or `false` under [integrator].

        parameters: {name: default} (a scene's [parameters]): symbols of the exact phase, usable polynomially in H and
        the Casimirs (not in the brackets), each default exact ("2", "-1/3", "0.05" is 1/20; an int; a float is read
        as its shortest repr). The exact phase runs once with them as symbols; every run takes values with
        parameters= (step, integrate, integrate_ensemble, the evaluators), without rebuilding it."""
        coordinates = _strings("coordinates", coordinates, "coordinate names")
        if not isinstance(brackets, _abc.Mapping):
            raise InputError(f"brackets: must be a dict like {{\"x1,x2\": \"-x3\"}}, got {_shown(brackets)}")
        brackets = dict(brackets)
        for k, v in brackets.items():
            _polynomial(f"brackets.\"{k}\"", v)
        _polynomial("hamiltonian", hamiltonian)
        casimirs = _strings("casimirs", casimirs, "polynomial strings")
        for i, c in enumerate(casimirs):
            _polynomial(f"casimirs[{i}]", c)
        order = _count("order", order, 1, _MAX_ORDER)
        if not isinstance(realisation, str):
            raise InputError(f"realisation: must be a string like \"auto\", got {_shown(realisation)}")
        dt = _positive_float("dt", dt)
        x0 = _state("x0", x0, len(coordinates))
        t_end = _nonnegative_float("t_end", t_end)
        max_terms = _count("max_terms", max_terms, 1, _MAX_COUNT)
        max_seconds, max_memory_mb = _exact_budget(max_seconds, max_memory_mb)
        trust_jacobi, jit = _flag("trust_jacobi", trust_jacobi), _jit(jit)
        defaults = _parameter_defaults(parameters)
        self._core = _Scheme(coordinates, brackets, hamiltonian, casimirs, order, realisation, dt, x0, t_end, max_terms,
                             trust_jacobi, jit, defaults, max_seconds, max_memory_mb or 0)
        self._description = ("values", dict(coordinates=coordinates, brackets=brackets, hamiltonian=hamiltonian,
                                            casimirs=casimirs, order=order, realisation=realisation, dt=dt,
                                            x0=None if x0 is None else x0.tolist(), t_end=t_end, max_terms=max_terms,
                                            trust_jacobi=trust_jacobi, jit=jit, parameters=dict(defaults),
                                            max_seconds=max_seconds, max_memory_mb=max_memory_mb))

    @classmethod
    def from_toml(cls, path, trust_jacobi=False, jit=None, max_seconds=60, max_memory_mb=None,
                  max_terms=20_000_000):
        """The scene file's scheme (its dt, x0 and t_end become the defaults). trust_jacobi and the exact phase's
        budget (max_seconds, max_memory_mb, max_terms) as for Scheme(); jit=True or False overrides the scene's
        integrator.jit (as `pgi --jit` and `--no-jit`); None keeps it."""
        arguments = _toml_arguments(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms)
        if "\0" in str(path):
            raise SceneError(f"{str(path)!r}: not a file name (it holds a NUL byte)")
        try:  # the text, so a pickled Scheme carries the scene itself; opened without blocking (a FIFO would wait)
            fd = _os.open(path, _os.O_RDONLY | _os.O_NONBLOCK)
        except OSError:
            fd = None
        info = None if fd is None else _os.fstat(fd)
        if info is None or not _stat.S_ISREG(info.st_mode) or info.st_size > _max_scene_bytes:
            # pgi's own reader refuses it: its SceneError names the file and why (not a file, its size)
            if fd is not None:
                _os.close(fd)
            _Scheme.from_toml(str(path), *_toml_core_arguments(*arguments))
            raise SceneError(f"{path}: cannot be read as a scene file")
        with _os.fdopen(fd, "rb") as f:  # (at most one byte past the limit, should the file grow meanwhile)
            text = f.read(_max_scene_bytes + 1)
        return cls._from_toml_text(text, str(path), *arguments)

    @classmethod
    def _from_toml_text(cls, text, file, trust_jacobi=False, jit=None, max_seconds=60, max_memory_mb=None,
                        max_terms=20_000_000):
        arguments = _toml_arguments(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms)
        s = cls.__new__(cls)
        s._core = _Scheme.from_toml_text(text, file, *_toml_core_arguments(*arguments))
        s._description = ("toml", text, file, *arguments)
        return s

    @property
    def description(self):
        """What rebuilds this Scheme elsewhere: ("values", the constructor's arguments) or ("toml", the scene's
        text, its file name, trust_jacobi, jit, max_seconds, max_memory_mb, max_terms). Pickling a Scheme sends this; the exact work is redone (once) where it lands."""
        return self._description

    def __reduce__(self):
        return (_rebuild, (self._description,))

    # The scheme's values (read-only).
    coordinates = property(lambda self: self._core.coordinates, doc="The coordinates' names (list of str).")
    parameters = property(lambda self: dict(self._core.parameters),
                          doc="The parameters and their defaults, exact ({name: \"1/2\"}; {} for none).")
    order = property(lambda self: self._core.order, doc="k, the Hamilton-Jacobi truncation order (1..64).")
    method_order = property(lambda self: self._core.method_order,
                            doc="The order the method converges with: 2 ceil(k/2).")
    realisation = property(lambda self: self._core.realisation, doc="The realisation used (\"lie-poisson\", ...).")
    structure_class = property(lambda self: self._core.structure_class,
                               doc="The class of pi (\"constant\", \"linear\", \"quadratic\", ...).")
    hamiltonian = property(lambda self: self._core.hamiltonian, doc="H as pgi writes it (str).")
    casimirs = property(lambda self: self._core.casimirs, doc="The Casimirs as pgi writes them (list of str).")
    dt = property(lambda self: self._core.dt, doc="The default step size (None: none given).")
    x0 = property(lambda self: self._core.x0, doc="The default initial state, shape (n,) (None: none given).")
    t_end = property(lambda self: self._core.t_end, doc="The default final time (None: none given).")
    name = property(lambda self: self._core.name, doc="The scene's name (\"\" for a Scheme from values).")
    jacobi_trusted = property(lambda self: self._core.jacobi_trusted,
                              doc="True when made with trust_jacobi=True: the Jacobi identity is not checked.")
    jit = property(lambda self: self._core.jit,
                   doc="The native-code policy: None (automatic, the default), True (always) or False (never).")

    def check(self):
        """The checks of the structure, as `pgi check --json`: {"class", "jacobi": {"holds": True} or the failing
        triple and its jacobiator, "casimirs": [{"C", "holds", ...}], "realisation": ..., "ok"}. Reports, never
        raises for a failed check (require_valid() raises)."""
        return self._core.check()

    def require_valid(self):
        """Raises InputError naming what check() found failing (the Jacobi triple and its jacobiator, a false
        Casimir); nothing if the scheme is valid. terms(), step() and the runs call it first."""
        self._core.require_valid()

    def terms(self, latex=False):
        """S_1..S_k, the exact Hamilton-Jacobi terms of the generating function, as strings (LaTeX with
        latex=True). Computed once (the exact phase). Raises InputError for an invalid scheme."""
        return self._core.terms(_flag("latex", latex))

    def modified_hamiltonian(self, upto=4, latex=False):
        """H_0..H_upto (upto: 0..64), the modified Hamiltonian's terms in powers of dt, as strings (LaTeX with
        latex=True): the method is the exact flow of H_0 + dt H_1 + ... Raises InputError for an invalid scheme."""
        return self._core.modified_hamiltonian(_count("upto", upto, 0, _MAX_UPTO), _flag("latex", latex))

    def realisation_terms(self, degree):
        """The realisation's terms up to total degree `degree` (0..100) in the momenta:
        {"method", "degree", "alpha": [...], "beta": [...]}."""
        return self._core.realisation_terms(_count("degree", degree, 0, _MAX_DEGREE))

    def terms_sympy(self):
        """S_1..S_k as sympy expressions (needs sympy)."""
        return _sympy(self.terms(), self.coordinates + list(self.parameters))

    def modified_hamiltonian_sympy(self, upto=4):
        """H_0..H_upto as sympy expressions (needs sympy)."""
        return _sympy(self.modified_hamiltonian(upto), self.coordinates + list(self.parameters))

    def step(self, x, dt=None, parameters=None):
        """One step of size dt (default: the scheme's) from x (shape (n,)): the new state as a numpy array. The
        compiled step for a dt is built once, sized at the scheme's x0 or else at the first x stepped with
        that dt. parameters: {name: value} (the defaults for those not given). Raises StepFailure if the step is
        not solved to round-off."""
        n = len(self.coordinates)
        if x is None:
            raise InputError("x: missing: give the state to step from")
        r = self._core._step(_state("x", x, n), _positive_float("dt", dt), _parameter_values(parameters))
        if not r["ok"]:
            raise StepFailure(r["message"], 1, 0.0, r["residual"])
        return r["x"]

    def step_jacobian(self, x, dt=None, parameters=None):
        """The derivative of the step of size dt (default: the scheme's) at x (shape (n,)): d step(x) / dx, a numpy
        array of shape (n, n), exact to round-off by the implicit function theorem on the step's equation (not
        finite differences, not a derivative of Newton's iterations; docs/math.md). A Poisson map's: J pi(x) J^T
        = pi(step(x)) and grad C(step(x)) J = grad C(x) for each Casimir C. The compiled step is step()'s; parameters
        as step() takes them (the derivative in x at those values). Raises InputError for a bad x or dt, StepFailure
        if the step is not solved to round-off."""
        n = len(self.coordinates)
        if x is None:
            raise InputError("x: missing: give the state to step from")
        r = self._core._step_jacobian(_state("x", x, n), _positive_float("dt", dt), _parameter_values(parameters))
        if not r["ok"]:
            raise StepFailure(r["message"], 1, 0.0, r["residual"])
        return r["jacobian"]

    def lyapunov(self, x0=None, dt=None, t_end=None, every=1, max_steps=None, max_output_mb=None, parameters=None):
        """Lyapunov exponents of the step of dt from x0 (defaults: the scheme's) over ceil(t_end/dt) steps, by
        Benettin's method: tangent vectors carried by the exact step Jacobian (step_jacobian), re-orthonormalised by
        QR after every step. Returns a LyapunovResult: the estimates every `every` steps and at the last
        (r.t, r.exponents of shape (rows, n)) and r.spectrum (n,). The vectors start tangent to the Casimirs' level
        set at x0 and stay so: the exponents on the leaf come first, those across it are reported as exactly 0.
        Raises InputError for a bad argument (x0 where the Casimirs' gradients are dependent too), ResourceLimitError
        above max_steps or max_output_mb (as integrate), StepFailure (with .result) if a step fails. parameters:
        {name: value} for the run, as integrate takes them."""
        n = len(self.coordinates)
        r = LyapunovResult(self._core._lyapunov(_state("x0", x0, n), _positive_float("dt", dt),
                                                _nonnegative_float("t_end", t_end), _count("every", every, 1, _MAX_COUNT),
                                                **_limits(max_steps, max_output_mb),
                                                parameters=_parameter_values(parameters)))
        if r.status != "ok":
            raise StepFailure(r.message, r.failed_step, r.failed_t, r.residual, r)
        return r

    def integrate(self, x0=None, dt=None, t_end=None, every=1, x_typical=None, events=None, event_samples=1,
                  max_steps=None, max_output_mb=None, tangent=False, parameters=None, t_eval=None):
        """ceil(t_end/dt) steps from x0 (defaults: the scheme's), Kahan-summed, recording every `every`-th
        state and the last; returns a Result. Runs with the GIL released; Ctrl-C stops it (KeyboardInterrupt)
        within a step. Raises StepFailure (with .result holding the run up to the failure) if a step fails. The compiled step is built at x0, or at
        x_typical when given (an ensemble's x_typical gives its run of this trajectory, bit for bit).

        Budgets, checked before any work (ResourceLimitError, as `pgi integrate` exits 4): max_steps (default
        1e8) steps, max_output_mb (default 1024) MB of recorded rows kept in memory, event_samples at most 10000,
        at most 256 events.

        events: a list of polynomials g(x) in the coordinates whose zeros are reported, each "g", a tuple
        (g, direction, terminal) (direction +1: g rising through 0, -1: falling, 0: both, the default;
        terminal: the run stops at its first crossing, default False) or a dict with those keys. Crossings
        are located to round-off on the step's dense output (the method's order) and returned as
        r.event_index, r.event_t, r.event_x, r.event_step; a terminal crossing is the run's last row and
        r.status is "terminal_event". event_samples > 1 also tests that many - 1 interior points of each
        step (two crossings inside one step). A bad event raises ValueError naming it (events[i]) and,
        for a polynomial, the problem and its position.

        tangent=True: r.jacobian (n, n) is the derivative of the run's map, d r.x[-1] / d x0, the product of the
        steps' Jacobians (step_jacobian) computed alongside the steps (not with a terminal event).

        parameters: {name: value}, the values of the scheme's parameters for this run (the defaults for those not
        given); the exact phase is not redone for new values.

        t_eval: times in [0, t_end], strictly increasing: the rows are at these times instead (r.t equals t_eval;
        every is ignored). Each row between two steps is a true step of the same method, of size t - t_n, from the
        state at t_n, so it keeps the Casimirs as every step does (no interpolant); the run goes on from its own
        states, so its steps, final state and jacobian are those without t_eval. A partial step that fails raises
        StepFailure naming the requested time."""
        n = len(self.coordinates)
        specs = _events(events)
        r = Result(self._core._integrate(_state("x0", x0, n), _positive_float("dt", dt), _nonnegative_float("t_end", t_end),
                                         _count("every", every, 1, _MAX_COUNT), _state("x_typical", x_typical, n), specs,
                                         _count("event_samples", event_samples, 1, _MAX_COUNT),
                                         **_limits(max_steps, max_output_mb), tangent=_flag("tangent", tangent),
                                         parameters=_parameter_values(parameters), t_eval=_times("t_eval", t_eval)))
        if r.status not in ("ok", "terminal_event"):
            raise StepFailure(r.message, r.failed_step, r.failed_t, r.residual, r)
        _warn_energy(int(r.energy_warning), None, r.dt)
        return r

    def integrate_ensemble(self, X0, dt=None, t_end=None, threads=None, chunk=None, x_typical=None, batch=None,
                           max_steps=None, max_output_mb=None, parameters=None, every=None, t_eval=None, events=None,
                           event_samples=1, tangent=False):
        """Every row of X0 (an (m, n) float64 numpy array; nested lists are converted) over ceil(t_end/dt)
        steps, on `threads` cores (default: all), the GIL released; returns an EnsembleResult. Each row's
        numbers equal integrate(row, dt, t_end, x_typical=result.x_typical) bit for bit, whatever threads and
        chunk (trajectories per task) and batch (trajectories stepped together, structure of arrays; 1: one
        at a time; default 16 below 40 coordinates, else 1). The step is built once, at x_typical (default: the finite row of largest
        norm). A row that is not finite or a step that fails ends that trajectory with its status (the one its
        single run ends with); nothing is raised for it. Raises ValueError (before any work) for X0 of the
        wrong shape or dtype, ResourceLimitError above max_steps (default 1e8) steps per trajectory or
        max_output_mb (default 1024) MB of results. Ctrl-C stops it (KeyboardInterrupt) within a step.

        parameters: {name: value or (m,) array}: the scheme's parameter values, one for every trajectory or one per
        row of X0 (a sweep in one call; the defaults for those not given). x_typical (n values) is extended with the
        value of largest magnitude over the rows of each parameter; result.x_typical holds its coordinates. A row's
        single run then shares its bits when it runs on the same Scheme, which keeps the ensemble's step and serves
        it to a row whose every value has the sign of the one the step was built at (a row of another sign, or a
        fresh Scheme, builds a step of its own: the same numbers to round-off, not bit for bit).

        Recording, each trajectory as its single run integrate(row, ..., x_typical=result.x_typical) records it, bit
        for bit (the trajectories then run one at a time per thread: batch does not apply):
        every=K or t_eval=times: result.x has shape (m, records, n), the rows at result.t (records,) (0, K dt, ...,
        the last step's; or t_eval), and result.x_final (m, n) holds the final states; result.rows (m,) counts each
        trajectory's rows, NaN after them (a failed trajectory; with every, one a terminal event ended has its
        crossing as its last row, at its event_t, as its single run has). events (as integrate takes them): result.event_row, event_index, event_t,
        event_x, event_step (one entry per crossing, by trajectory then time), terminal_event (m,) bool; a
        trajectory a terminal crossing ended has status "terminal_event". tangent=True: result.jacobian (m, n, n).
        max_output_mb bounds the rows and tangent maps kept, checked before any work."""
        X0 = _states(X0)
        r = EnsembleResult(self._core._integrate_ensemble(
            X0, _positive_float("dt", dt), _nonnegative_float("t_end", t_end),
            _optional_count("threads", threads, 1, _MAX_COUNT) or 0, _optional_count("chunk", chunk, 1, _MAX_COUNT) or 0,
            _state("x_typical", x_typical, len(self.coordinates)), _optional_count("batch", batch, 1, _MAX_COUNT) or 0,
            **_limits(max_steps, max_output_mb), parameters=_parameter_values(parameters),
            recording=_recording(every, t_eval, events, event_samples, tangent)))
        _warn_energy(int(r.energy_warning.sum()), len(r.energy_warning), r.dt)
        return r

    def _check_ensemble(self, m, dt=None, t_end=None, max_steps=None, max_output_mb=None, every=None, t_eval=None,
                        events=None, event_samples=1, tangent=False):
        """integrate_ensemble's checks of dt, t_end, what is recorded and the budgets for m rows, without running
        (pgi.dask)."""
        self._core._check_ensemble(m, _positive_float("dt", dt), _nonnegative_float("t_end", t_end),
                                   **_limits(max_steps, max_output_mb),
                                   recording=_recording(every, t_eval, events, event_samples, tangent))

    def typical_state(self, X0):
        """The row integrate_ensemble builds its step at by default: the finite row of largest norm (None if none)."""
        return self._core._typical_state(_states(X0))

    def stats(self):
        """How many times each exact artefact was computed (each is computed once): {"realisation_builds",
        "terms_builds" (S_1..S_k), "modified_builds" (the modified Hamiltonian), "stepper_builds" (compiled steps),
        "steppers_kept", "evaluator_builds" (the evaluators' compiled maps: one each, one per upto)}."""
        return self._core.stats()

    # The numeric evaluators: each from the exact polynomials, compiled once per scheme (per upto for the modified
    # Hamiltonian), at one state x of shape (n,) (checked as step()'s x) or at m states, the rows of an (m, n)
    # float64 array (checked as integrate_ensemble's X0), with the GIL released. A row's values are the same bits
    # alone or among others. A wrong shape or dtype, or a value that is not finite, raises InputError naming x.
    # parameters: {name: value, or an (m,) array of one value per row} (the defaults for those not given).
    def _evaluated(self, method, x, *args, parameters=None):
        """The core's method at x's rows, and the first row's values alone if x was one state."""
        X = _states(x, "x")
        one = X.ndim != 2
        if one:
            X = _state("x", X, len(self.coordinates))[None, :]
        values = getattr(self._core, method)(X, *args, parameters=_parameter_values(parameters))
        return values[0] if one else values

    def vector_field(self, x, parameters=None):
        """pi(x) grad H(x), the time derivative of the flow (units of x per unit of time): shape (n,) for x of shape
        (n,), (m, n) for x of shape (m, n). scipy's solve_ivp takes it as lambda t, x: s.vector_field(x). It needs
        no exact phase, and is computed even for a scheme that fails its checks."""
        return self._evaluated("_vector_field", x, parameters=parameters)

    def poisson_matrix(self, x, parameters=None):
        """pi(x), entry [i, j] the bracket {x_i, x_j} at x: shape (n, n) for x of shape (n,), (m, n, n) for x of
        shape (m, n). Skew-symmetric with a zero diagonal, exactly."""
        n = len(self.coordinates)
        P = self._evaluated("_poisson_matrices", x, parameters=parameters)
        return P.reshape((n, n) if P.ndim == 1 else (len(P), n, n))

    def hamiltonian_value(self, x, parameters=None):
        """H(x) (units of H): a float for x of shape (n,), shape (m,) for x of shape (m, n)."""
        return self._evaluated("_hamiltonian_values", x, parameters=parameters)

    def casimir_values(self, x, parameters=None):
        """The Casimirs at x, in the order of s.casimirs: shape (c,) for x of shape (n,), (m, c) for x of shape
        (m, n) (c = len(s.casimirs), possibly 0)."""
        return self._evaluated("_casimir_values", x, parameters=parameters)

    def modified_hamiltonian_value(self, x, dt=None, upto=4, parameters=None):
        """H_0(x) + dt H_1(x) + ... + dt^upto H_upto(x) (units of H), the modified Hamiltonian that the method of
        step dt (default: the scheme's; positive, finite, time units) conserves up to O(dt^(upto+1)); H_0..H_upto are
        modified_hamiltonian(upto), upto in 0..64. A float for x of shape (n,), shape (m,) for x of shape (m, n). The
        first call for an upto runs the exact phase (once; Ctrl-C raises KeyboardInterrupt); raises InputError for an
        invalid scheme, as terms() does."""
        return self._evaluated("_modified_hamiltonian_values", x, _positive_float("dt", dt),
                               _count("upto", upto, 0, _MAX_UPTO), parameters=parameters)

    def __repr__(self):
        c = self._core
        return f"pgi.Scheme(coordinates={c.coordinates}, order={c.order}, realisation={c.realisation!r}, class={c.structure_class!r})"
