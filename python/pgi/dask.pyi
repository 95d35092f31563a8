# Type stubs of pgi.dask (checked by ctest python_stubs).
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy.typing as npt

from . import EnsembleResult, Scheme

__all__ = ["integrate_ensemble", "sweep"]

def integrate_ensemble(client: Any, scheme: Scheme, X0: npt.ArrayLike, dt: float | None = None,
                       t_end: float | None = None, chunks: int | None = None, threads: int = 1, retries: int = 2,
                       max_steps: int | None = None, max_output_mb: float | None = None,
                       parameters: Mapping[str, float | npt.ArrayLike] | None = None, every: int | None = None,
                       t_eval: npt.ArrayLike | None = None, events: Sequence[Any] | None = None,
                       event_samples: int = 1, tangent: bool = False) -> EnsembleResult: ...
def sweep(client: Any, runs: Iterable[Mapping[str, Any]], chunks: int | None = None, threads: int = 1,
          retries: int = 2, max_steps: int | None = None, max_output_mb: float | None = None) -> list[EnsembleResult]: ...
