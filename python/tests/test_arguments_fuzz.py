"""The Python argument conversion under generated hostile values (hypothesis): every public entry point either
runs or raises one of pgi's documented exceptions (InputError, ResourceLimitError, StepFailure) naming the problem;
never pybind11's raw TypeError, a SystemError, a crash, nor a run past its budget."""
import tempfile
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402
from hypothesis.configuration import set_hypothesis_home_dir  # noqa: E402

# hypothesis keeps caches in a home directory (./.hypothesis by default): a temporary one, removed at exit
_HOME = tempfile.TemporaryDirectory(prefix="pgi-hypothesis-")
set_hypothesis_home_dir(_HOME.name)

import pgi  # noqa: E402
from test_scheme import RIGID_BODY  # noqa: E402

SCHEME = pgi.Scheme(**RIGID_BODY)
DOCUMENTED = (pgi.InputError, pgi.ResourceLimitError, pgi.StepFailure)

# what a caller might pass where a number, a count, a state or a list is expected
scalars = st.one_of(st.none(), st.booleans(), st.integers(min_value=-2**70, max_value=2**70),
                    st.floats(allow_nan=True, allow_infinity=True), st.complex_numbers(allow_nan=True),
                    st.text(max_size=12), st.binary(max_size=8))
arrays = st.one_of(scalars, st.lists(scalars, max_size=5),
                   st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=0, max_size=7).map(np.array),
                   st.lists(st.lists(st.floats(-2, 2), min_size=3, max_size=3), min_size=1, max_size=3).map(np.array),
                   st.sampled_from([np.zeros((2, 3), dtype=np.complex128), np.zeros((2, 3), dtype=np.float32),
                                    np.zeros((0, 3)), np.zeros((2, 3, 1)), np.array(["a", "b", "c"])]))
# derandomized: every run tries the same examples (run with derandomize=False and more examples to search anew);
# no example database: the tests write nothing into the source tree
fuzz = settings(max_examples=150, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))


def documented(call):
    """Runs call: a result, or one of pgi's documented exceptions whose message names the problem in one line."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pgi.EnergyWarning)
        try:
            call()
        except DOCUMENTED as e:
            message = str(e)
            assert message and "incompatible function arguments" not in message
            assert len(message) < 2000


@fuzz
@given(x0=arrays, dt=scalars, t_end=scalars, every=scalars)
def test_integrate_runs_or_refuses_with_a_documented_error(x0, dt, t_end, every):
    # a tiny run at most: a value that would make it long is refused by the step budget
    documented(lambda: SCHEME.integrate(x0, dt=dt, t_end=t_end, every=every, max_steps=2000))


@fuzz
@given(X0=arrays, dt=scalars, t_end=scalars, threads=scalars, batch=scalars)
def test_integrate_ensemble_runs_or_refuses_with_a_documented_error(X0, dt, t_end, threads, batch):
    documented(lambda: SCHEME.integrate_ensemble(X0, dt=dt, t_end=t_end, threads=threads, batch=batch, max_steps=2000))


@fuzz
@given(x=arrays, dt=scalars)
def test_step_runs_or_refuses_with_a_documented_error(x, dt):
    documented(lambda: SCHEME.step(x, dt=dt))


@fuzz
@given(order=scalars, upto=scalars, hamiltonian=st.one_of(scalars, st.sampled_from(["x1**2", "x1^2 + (", "x9", "1e999"])),
       casimirs=st.one_of(scalars, st.lists(st.text(max_size=6), max_size=2)))
def test_a_scheme_is_built_or_refused_with_a_documented_error(order, upto, hamiltonian, casimirs):
    def build():
        s = pgi.Scheme(RIGID_BODY["coordinates"], RIGID_BODY["brackets"], hamiltonian, casimirs=casimirs, order=order)
        s.modified_hamiltonian(upto)
    documented(build)
