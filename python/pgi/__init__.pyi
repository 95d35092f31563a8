# Type stubs of the package pgi (PEP 561; checked against the module by ctest python_stubs: mypy.stubtest).
# Shapes: n coordinates, m trajectories or recorded rows, c Casimirs.
from collections.abc import Mapping, Sequence
from os import PathLike
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from ._pgi import InputError as InputError
from ._pgi import NativeCodeError as NativeCodeError
from ._pgi import ResourceLimitError as ResourceLimitError
from ._pgi import SceneError as SceneError
from ._pgi import __version__ as __version__

__all__ = ["Scheme", "Result", "EnsembleResult", "LyapunovResult", "StepFailure", "EnergyWarning", "InputError", "SceneError",
           "ResourceLimitError", "NativeCodeError", "__version__"]

_Array = npt.NDArray[np.float64]
# parameter values of a run: {name: a number, or an (m,) array of one value per trajectory or row}
_Parameters = Mapping[str, float | npt.ArrayLike]
_State = Union[Sequence[float], npt.ArrayLike]
_Event = Union[str, tuple[str], tuple[str, int], tuple[str, int, bool], Mapping[str, Any]]

class EnergyWarning(UserWarning): ...

class StepFailure(ArithmeticError):
    step: int
    t: float
    residual: float
    result: Result | LyapunovResult | None
    def __init__(self, message: str, step: int, t: float, residual: float,
                 result: Result | LyapunovResult | None = None) -> None: ...

class Result:
    """A run (Scheme.integrate): arrays of shape (rows,), (rows, n), (rows, c)."""
    t: _Array
    x: _Array
    energy_error: _Array
    casimir_error: _Array
    energy_error_max: float
    casimir_error_max: list[float]
    casimir_drift_per_step: _Array
    energy_warning: bool
    steps: int
    dt: float
    newton_iterations_mean: float
    newton_iterations_max: int
    status: str
    message: str
    failed_step: int
    failed_t: float
    residual: float
    event_index: npt.NDArray[np.int64]
    event_t: _Array
    event_x: _Array
    event_step: npt.NDArray[np.int64]
    jacobian: _Array  # (n, n), with integrate(tangent=True) only
    def __init__(self, d: Mapping[str, Any]) -> None: ...

class LyapunovResult:
    """Lyapunov exponents (Scheme.lyapunov), 1/time units: t (rows,), exponents (rows, n), spectrum (n,)."""
    t: _Array
    exponents: _Array
    spectrum: _Array
    leaf_dim: int
    steps: int
    dt: float
    status: str
    message: str
    failed_step: int
    failed_t: float
    residual: float
    def __init__(self, d: Mapping[str, Any]) -> None: ...

class EnsembleResult:
    """An ensemble (Scheme.integrate_ensemble, pgi.dask): per trajectory, arrays of shape (m,), (m, n), (m, c);
    recording, x of shape (m, records, n) and what was asked for (t, rows, event_*, jacobian)."""
    x: _Array
    x_final: _Array
    t: _Array
    rows: npt.NDArray[np.int64]
    terminal_event: npt.NDArray[np.bool_]
    event_row: npt.NDArray[np.int64]
    event_index: npt.NDArray[np.int64]
    event_t: _Array
    event_x: _Array
    event_step: npt.NDArray[np.int64]
    jacobian: _Array
    energy_error: _Array
    casimir_error: _Array
    status: npt.NDArray[np.str_]
    steps: npt.NDArray[np.uint64]
    failed_step: npt.NDArray[np.uint64]
    failed_t: _Array
    residual: _Array
    newton_iterations_mean: _Array
    newton_iterations_max: npt.NDArray[np.int32]
    energy_warning: npt.NDArray[np.bool_]
    x_typical: _Array | None
    threads: int | None
    dt: float
    t_end: float
    def __init__(self, d: Mapping[str, Any]) -> None: ...
    @property
    def ok(self) -> npt.NDArray[np.bool_]: ...

class Scheme:
    def __init__(self, coordinates: Sequence[str], brackets: Mapping[str, str], hamiltonian: str,
                 casimirs: Sequence[str] = (), order: int = 2, realisation: str = "auto", dt: float | None = None,
                 x0: _State | None = None, t_end: float | None = None, max_terms: int = 20_000_000,
                 trust_jacobi: bool = False, jit: bool | None = None,
                 parameters: Mapping[str, str | int | float] | None = None, max_seconds: float | None = 60,
                 max_memory_mb: int | None = None) -> None: ...
    @classmethod
    def from_toml(cls, path: str | PathLike[str], trust_jacobi: bool = False, jit: bool | None = None,
                  max_seconds: float | None = 60, max_memory_mb: int | None = None,
                  max_terms: int = 20_000_000) -> Scheme: ...
    @property
    def description(self) -> tuple[Any, ...]: ...
    def __reduce__(self) -> tuple[Any, ...]: ...
    @property
    def coordinates(self) -> list[str]: ...
    @property
    def parameters(self) -> dict[str, str]: ...
    @property
    def order(self) -> int: ...
    @property
    def method_order(self) -> int: ...
    @property
    def realisation(self) -> str: ...
    @property
    def structure_class(self) -> str: ...
    @property
    def hamiltonian(self) -> str: ...
    @property
    def casimirs(self) -> list[str]: ...
    @property
    def dt(self) -> float | None: ...
    @property
    def x0(self) -> _Array | None: ...
    @property
    def t_end(self) -> float | None: ...
    @property
    def name(self) -> str: ...
    @property
    def jacobi_trusted(self) -> bool: ...
    @property
    def jit(self) -> bool | None: ...
    def check(self) -> dict[str, Any]: ...
    def require_valid(self) -> None: ...
    def terms(self, latex: bool = False) -> list[str]: ...
    def modified_hamiltonian(self, upto: int = 4, latex: bool = False) -> list[str]: ...
    def realisation_terms(self, degree: int) -> dict[str, Any]: ...
    def terms_sympy(self) -> list[Any]: ...
    def modified_hamiltonian_sympy(self, upto: int = 4) -> list[Any]: ...
    def step(self, x: _State, dt: float | None = None, parameters: _Parameters | None = None) -> _Array: ...
    def step_jacobian(self, x: _State, dt: float | None = None, parameters: _Parameters | None = None) -> _Array: ...
    def lyapunov(self, x0: _State | None = None, dt: float | None = None, t_end: float | None = None, every: int = 1,
                 max_steps: int | None = None, max_output_mb: float | None = None,
                 parameters: _Parameters | None = None) -> LyapunovResult: ...
    def integrate(self, x0: _State | None = None, dt: float | None = None, t_end: float | None = None, every: int = 1,
                  x_typical: _State | None = None, events: Sequence[_Event] | None = None, event_samples: int = 1,
                  max_steps: int | None = None, max_output_mb: float | None = None, tangent: bool = False,
                  parameters: _Parameters | None = None, t_eval: npt.ArrayLike | None = None) -> Result: ...
    def integrate_ensemble(self, X0: npt.ArrayLike, dt: float | None = None, t_end: float | None = None,
                           threads: int | None = None, chunk: int | None = None, x_typical: _State | None = None,
                           batch: int | None = None, max_steps: int | None = None,
                           max_output_mb: float | None = None, parameters: _Parameters | None = None,
                           every: int | None = None, t_eval: npt.ArrayLike | None = None,
                           events: Sequence[_Event] | None = None, event_samples: int = 1,
                           tangent: bool = False) -> EnsembleResult: ...
    def typical_state(self, X0: npt.ArrayLike) -> _Array | None: ...
    def stats(self) -> dict[str, int]: ...
    def vector_field(self, x: npt.ArrayLike, parameters: _Parameters | None = None) -> _Array: ...
    def poisson_matrix(self, x: npt.ArrayLike, parameters: _Parameters | None = None) -> _Array: ...
    def hamiltonian_value(self, x: npt.ArrayLike, parameters: _Parameters | None = None) -> float | _Array: ...
    def casimir_values(self, x: npt.ArrayLike, parameters: _Parameters | None = None) -> _Array: ...
    def modified_hamiltonian_value(self, x: npt.ArrayLike, dt: float | None = None, upto: int = 4,
                                   parameters: _Parameters | None = None) -> float | _Array: ...
