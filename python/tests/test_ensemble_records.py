"""Ensembles that record: rows every K steps (on lanes) or at requested times, crossings of events per trajectory and
tangent maps, each trajectory's equal to its single run bit for bit on one thread or many, in batches of any size;
budgets on what is recorded checked before any work."""
import numpy as np
import pytest

import pgi
from conftest import SCENES


def states(m, seed=3):
    X0 = np.random.default_rng(seed).uniform(-1.2, 1.2, size=(m, 3))
    X0[2] = [np.nan, 0.1, 0.2]  # a row that is not finite: NaN rows, no crossing
    return X0


def single(s, e, X0, i, **kw):
    return s.integrate(X0[i], dt=e.dt, t_end=e.t_end, x_typical=e.x_typical, **kw)


@pytest.mark.parametrize("kw", [dict(every=7), dict(every=1), dict(t_eval=np.linspace(0, 3.05, 41)),
                                dict(every=5, events=["x2", ("x1 - x3", 1, False)], tangent=True),
                                dict(t_eval=[0.0, 1.0, 2.5], events=[("x2", 0, True)])])
def test_recorded_rows_crossings_and_jacobians_are_the_single_runs(kw):
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X0 = states(11)
    one = s.integrate_ensemble(X0, dt=0.1, t_end=3.05, threads=1, **kw)
    m, n = X0.shape
    assert one.x.shape == (m, len(one.t), n) and one.x_final.shape == (m, n) and one.rows.shape == (m,)
    if "t_eval" in kw:
        assert one.t.tolist() == list(np.asarray(kw["t_eval"], dtype=float))
    assert one.status[2] == "non_finite_start" and one.rows[2] == 0 and np.isnan(one.x[2]).all()
    event_rows = []
    for i in [i for i in range(m) if i != 2]:
        r = single(s, one, X0, i, **{k: v for k, v in kw.items() if k != "every"}, every=kw.get("every", 1))
        k = len(r.t)
        assert one.rows[i] == k and one.status[i] == r.status
        assert np.array_equal(one.x[i, :k], r.x) and np.isnan(one.x[i, k:]).all()
        # with every, a terminal crossing is the single run's last row, at its own time; the others are on one.t
        crossing_row = r.status == "terminal_event" and "every" in kw
        on_grid = k - 1 if crossing_row else k
        assert np.array_equal(one.t[:on_grid], r.t[:on_grid])
        if r.status == "terminal_event":
            assert np.array_equal(one.x_final[i], r.event_x[-1])
        elif "every" in kw:
            assert np.array_equal(one.x_final[i], r.x[-1])
        mine = one.event_row == i if "events" in kw else None
        if "events" in kw:
            assert np.array_equal(one.event_t[mine], r.event_t) and np.array_equal(one.event_x[mine], r.event_x)
            assert np.array_equal(one.event_index[mine], r.event_index)
            assert np.array_equal(one.event_step[mine], r.event_step)
            event_rows += [i] * len(r.event_t)
        if kw.get("tangent"):
            assert np.array_equal(one.jacobian[i], r.jacobian)
    if "events" in kw:
        assert one.event_row.tolist() == event_rows and len(event_rows) > 0
        # numpy's index type: counts per trajectory and fancy indexing work as on any index array
        assert one.event_row.dtype == np.int64 and one.event_index.dtype == np.int64
        assert np.bincount(one.event_row, minlength=m).tolist() == [event_rows.count(i) for i in range(m)]
    for threads, chunk, batch in [(2, 1, None), (2, None, 1), (3, 4, 3), (1, None, 16)]:
        e = s.integrate_ensemble(X0, dt=0.1, t_end=3.05, threads=threads, chunk=chunk, batch=batch, **kw)
        assert np.array_equal(e.x, one.x, equal_nan=True) and np.array_equal(e.x_final, one.x_final, equal_nan=True)
        for f in ("t", "rows", "event_row", "event_t", "jacobian"):
            if hasattr(one, f):
                assert np.array_equal(getattr(e, f), getattr(one, f), equal_nan=True), f


def test_recorded_rows_keep_the_casimir_to_round_off():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X0 = np.random.default_rng(5).uniform(-1, 1, size=(8, 3))
    e = s.integrate_ensemble(X0, dt=0.1, t_end=20, t_eval=np.linspace(0, 20, 1000))
    C = (e.x ** 2).sum(axis=2)  # the Casimir |x|^2 at every requested time
    # each row is a step or a partial one: the Casimir's relative error a random walk of round-off over 200 steps
    assert np.abs(C / C[:, :1] - 1).max() < 64 * np.finfo(float).eps * np.sqrt(200)


def test_without_recording_x_stays_the_final_states():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X0 = states(5)
    e = s.integrate_ensemble(X0, dt=0.1, t_end=1)
    assert e.x.shape == (5, 3) and np.array_equal(e.x, e.x_final, equal_nan=True)
    assert not hasattr(e, "t") and not hasattr(e, "event_row") and not hasattr(e, "jacobian")
    tangent = s.integrate_ensemble(X0, dt=0.1, t_end=1, tangent=True)  # a tangent map only: x stays final
    assert tangent.x.shape == (5, 3) and tangent.jacobian.shape == (5, 3, 3) and np.isnan(tangent.jacobian[2]).all()
    assert np.array_equal(tangent.x, e.x, equal_nan=True)
    final = e.x_final.copy()
    e.x[:] = 7.0  # x is an array of its own: writing into it leaves x_final as the run left it
    assert np.array_equal(e.x_final, final, equal_nan=True) and not np.shares_memory(e.x, e.x_final)


def test_what_is_recorded_is_checked_and_budgeted_before_any_work():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X0 = states(4)
    with pytest.raises(pgi.InputError, match="every: 0 is not a whole number from 1"):
        s.integrate_ensemble(X0, dt=0.1, t_end=1, every=0)
    with pytest.raises(pgi.InputError, match=r"t_eval\[1\] = 0.5 .* increase strictly"):
        s.integrate_ensemble(X0, dt=0.1, t_end=1, t_eval=[0.7, 0.5])
    with pytest.raises(pgi.InputError, match=r"events\[0\]: malformed polynomial"):
        s.integrate_ensemble(X0, dt=0.1, t_end=1, events=["x1 +"])
    with pytest.raises(pgi.InputError, match="tangent: not with a terminal event"):
        s.integrate_ensemble(X0, dt=0.1, t_end=1, events=[("x1", 0, True)], tangent=True)
    with pytest.raises(pgi.ResourceLimitError, match=r"4 trajectories of 10001 recorded rows.*max_output_mb"):
        s.integrate_ensemble(X0, dt=1e-4, t_end=1, every=1, max_output_mb=1)
    # the same ensemble without rows fits
    assert s.integrate_ensemble(X0, dt=1e-2, t_end=1, max_output_mb=1).x.shape == (4, 3)
