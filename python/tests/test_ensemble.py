"""Ensembles from Python: each row equals its single run bit for bit whatever the threads, bad X0 refused
before any work, NaN rows and failing trajectories isolated; pickling a Scheme rebuilds it."""
import pickle
import warnings

import numpy as np
import pytest

import pgi
from conftest import SCENES
from test_scheme import RIGID_BODY


def states(m, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.5, 1.5, size=(m, 3))


def test_each_row_equals_its_single_run_whatever_the_threads_and_batches():
    s = pgi.Scheme(**RIGID_BODY)
    X0 = states(9)
    one = s.integrate_ensemble(X0, dt=0.1, t_end=3, threads=1)
    assert one.x.shape == (9, 3) and one.casimir_error.shape == (9, 1) and one.status.tolist() == ["ok"] * 9
    assert one.x_typical.tolist() == X0[np.argmax((X0 ** 2).sum(axis=1))].tolist()
    assert one.x_typical.tolist() == s.typical_state(X0).tolist()
    for i in range(9):
        r = s.integrate(X0[i], dt=0.1, t_end=3, every=30, x_typical=one.x_typical)
        assert r.x[-1].tolist() == one.x[i].tolist()
        assert r.energy_error_max == one.energy_error[i] and r.casimir_error_max[0] == one.casimir_error[i, 0]
        assert r.steps == one.steps[i] == 30 and r.newton_iterations_mean == one.newton_iterations_mean[i]
    for threads, chunk, batch in [(2, 1, None), (2, None, None), (3, 2, None), (1, None, 1), (2, 5, 4), (1, 9, 9)]:
        e = s.integrate_ensemble(X0, dt=0.1, t_end=3, threads=threads, chunk=chunk, batch=batch)
        assert e.threads == threads
        assert e.newton_iterations_mean.tolist() == one.newton_iterations_mean.tolist()
        assert np.array_equal(e.x, one.x) and np.array_equal(e.energy_error, one.energy_error)
        assert np.array_equal(e.casimir_error, one.casimir_error)


def test_bad_X0_is_a_value_error_before_any_work():
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(ValueError, match=r"X0: must have shape \(m, 3\), one column per coordinate, got \(4, 2\)"):
        s.integrate_ensemble(np.zeros((4, 2)), dt=0.1, t_end=1)
    with pytest.raises(ValueError, match=r"got \(3,\)"):
        s.integrate_ensemble(np.zeros(3), dt=0.1, t_end=1)
    with pytest.raises(ValueError, match="X0: must have dtype float64, got float32"):
        s.integrate_ensemble(np.zeros((4, 3), dtype=np.float32), dt=0.1, t_end=1)
    with pytest.raises(ValueError, match="X0: must have dtype float64, got int64"):
        s.integrate_ensemble(np.zeros((4, 3), dtype=np.int64), dt=0.1, t_end=1)
    with pytest.raises(ValueError, match="dt: missing"):
        s.integrate_ensemble(np.zeros((4, 3)), t_end=1)
    with pytest.raises(ValueError, match="threads: 0 is not a whole number from 1 to 2\\^53"):
        s.integrate_ensemble(np.zeros((4, 3)), dt=0.1, t_end=1, threads=0)
    with pytest.raises(ValueError, match="batch: 0 is not a whole number from 1"):
        s.integrate_ensemble(np.zeros((4, 3)), dt=0.1, t_end=1, batch=0)
    for flag in (True, np.bool_(True)):  # a bool is an int in Python: refused, not read as 1
        with pytest.raises(ValueError, match="batch: .*True is not a whole number from 1"):
            s.integrate_ensemble(np.zeros((4, 3)), dt=0.1, t_end=1, batch=flag)
    with pytest.raises(ValueError, match="batch: 5000 is above the limit of 1024"):
        s.integrate_ensemble(np.zeros((4, 3)), dt=0.1, t_end=1, batch=5000)
    # a Fortran-ordered array is read as the same rows
    X0 = states(4)
    assert np.array_equal(s.integrate_ensemble(np.asfortranarray(X0), dt=0.1, t_end=1).x,
                          s.integrate_ensemble(X0, dt=0.1, t_end=1).x)


def test_nan_row_and_failing_trajectory_end_alone():
    s = pgi.Scheme(**RIGID_BODY)
    X0 = states(6)
    clean = s.integrate_ensemble(X0, dt=0.1, t_end=2, threads=2)
    X0[1, 2] = np.nan
    X0[4] *= 1e4  # far beyond what the step built at the clean x_typical solves with dt = 0.1
    r = s.integrate_ensemble(X0, dt=0.1, t_end=2, threads=2, chunk=1, x_typical=clean.x_typical)
    assert r.status[1] == "non_finite_start" and r.steps[1] == 0 and np.isnan(r.energy_error[1])
    assert r.status[4] in ("newton_not_converged", "non_finite") and r.failed_step[4] == r.steps[4] + 1
    assert r.failed_t[4] == r.steps[4] * 0.1 and np.isfinite(r.x[4]).all()
    others = [0, 2, 3, 5]
    assert (r.status[others] == "ok").all() and np.array_equal(r.x[others], clean.x[others])
    assert r.ok.tolist() == [True, False, True, True, False, True]


def test_pickle_rebuilds_the_scheme_from_its_values_or_its_scene_text():
    for s in (pgi.Scheme(**RIGID_BODY, dt=0.1, t_end=2), pgi.Scheme.from_toml(SCENES / "rigid_body.toml")):
        t = pickle.loads(pickle.dumps(s))
        assert t.description == s.description and t.terms() == s.terms()
        assert t.dt == s.dt and t.t_end == s.t_end
        X0 = states(3)
        assert np.array_equal(t.integrate_ensemble(X0, t_end=2).x, s.integrate_ensemble(X0, t_end=2).x)
    with pytest.raises(pgi.SceneError, match="no_such_scene.toml"):
        pgi.Scheme.from_toml(SCENES / "no_such_scene.toml")


def test_x0_that_is_not_an_array_of_numbers_names_x0():
    s = pgi.Scheme(**RIGID_BODY)
    for X0, message in [([[1.0, 2.0, 3.0], [1.0]], "X0: must be an \\(m, n\\) array of numbers"),
                        ([["a", "b", "c"]], "X0: must be an \\(m, n\\) array of numbers"),
                        (np.zeros((2, 3, 1)), r"X0: must have shape \(m, 3\), one column per coordinate, got \(2, 3, 1\)"),
                        (np.zeros((2, 3), dtype=complex), "X0: must have dtype float64, got complex128"),
                        (np.zeros((2, 3), dtype=bool), "X0: must have dtype float64, got bool")]:
        with pytest.raises(pgi.InputError, match=message):
            s.integrate_ensemble(X0, dt=0.1, t_end=1)
    # no rows is not an error from Python (numpy's empty arrays): an empty result
    e = s.integrate_ensemble(np.zeros((0, 3)), dt=0.1, t_end=1)
    assert e.x.shape == (0, 3) and e.status.shape == (0,) and e.x_typical is None


# k = 1 on the rigid body at dt = 3: every step solves its equation, but from the scene's x0 the relative energy error
# reaches 0.13; a tenth of that state turns ten times slower (the error is O((dt |x|)^2))
DRIFTING = np.array([[0.4535961214255773, 0.0, 0.8912073600614354], [0.04535961214255773, 0.0, 0.08912073600614354]])


def test_energy_drift_past_a_tenth_warns_for_the_run_and_the_ensemble_names_the_trajectories():
    s = pgi.Scheme(**{**RIGID_BODY, "order": 1})
    with pytest.warns(pgi.EnergyWarning, match="the run reached a relative energy error above 0.1"):
        r = s.integrate(DRIFTING[0], dt=3, t_end=30)
    assert r.energy_warning and r.energy_error_max > 0.1
    with pytest.warns(pgi.EnergyWarning, match="1 of 2 trajectories"):
        e = s.integrate_ensemble(DRIFTING, dt=3, t_end=30, threads=1)
    assert e.energy_warning.tolist() == [True, False] and e.energy_error[1] < 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning where the energy follows H
        quiet = s.integrate(DRIFTING[1], dt=3, t_end=30)
        assert not quiet.energy_warning
        assert not s.integrate_ensemble(DRIFTING[1:], dt=3, t_end=30).energy_warning.any()
