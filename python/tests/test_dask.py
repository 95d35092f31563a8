"""pgi.dask on a LocalCluster of 2 worker processes: the local run's numbers bit for bit, the scheme rebuilt
once per worker, bad input refused before submitting, a failing chunk named."""
import numpy as np
import pytest

import pgi
from conftest import SCENES
from test_scheme import RIGID_BODY

distributed = pytest.importorskip("distributed")
import pgi.dask  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None,
                                       silence_logs=50)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def states(m):
    X0 = np.random.default_rng(7).uniform(-1.2, 1.2, size=(m, 3))
    X0[5, 0] = np.nan
    return X0


@pytest.mark.parametrize("make", [lambda: pgi.Scheme(**RIGID_BODY), lambda: pgi.Scheme.from_toml(SCENES / "rigid_body.toml")])
def test_dask_equals_the_local_run_bit_for_bit(client, make):
    s = make()
    X0 = states(23)
    local = s.integrate_ensemble(X0, dt=0.1, t_end=2, threads=2)
    d = pgi.dask.integrate_ensemble(client, s, X0, dt=0.1, t_end=2, chunks=4)
    assert d.chunks == 6
    for f in ("x", "energy_error", "casimir_error", "status", "steps", "failed_step", "newton_iterations_mean"):
        assert np.array_equal(getattr(d, f), getattr(local, f), equal_nan=f not in ("status", "steps", "failed_step")), f
    assert d.status[5] == "non_finite_start" and np.isnan(d.x[5, 0])
    assert d.x_typical.tolist() == local.x_typical.tolist()
    # each worker built this scheme once and kept it
    counts = client.run(lambda dask_worker: len(getattr(dask_worker, "_pgi_schemes", {})))
    assert all(1 <= n <= 2 for n in counts.values()) and sum(counts.values()) >= 1


def test_dask_records_rows_crossings_and_jacobians_as_the_local_run(client):
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X0 = states(13)
    kw = dict(dt=0.1, t_end=2, every=3, events=["x2", ("x1", 1, False)], tangent=True)
    local = s.integrate_ensemble(X0, threads=2, **kw)
    d = pgi.dask.integrate_ensemble(client, s, X0, chunks=4, **kw)
    assert d.x.shape == (13, len(local.t), 3) and len(local.event_row) > 0
    for f in ("x", "x_final", "t", "rows", "jacobian", "event_row", "event_index", "event_t", "event_x", "event_step",
              "terminal_event", "status"):
        assert np.array_equal(getattr(d, f), getattr(local, f), equal_nan=f != "status"), f
    with pytest.raises(pgi.ResourceLimitError, match="recorded rows"):  # refused before anything is submitted
        pgi.dask.integrate_ensemble(client, s, X0, dt=1e-4, t_end=1, every=1, max_output_mb=1)


def test_sweep_runs_each_ensemble_as_alone(client):
    X0 = states(8)
    runs = [dict(scheme=pgi.Scheme(**{**RIGID_BODY, "order": k}), X0=X0, dt=dt, t_end=1) for k, dt in [(2, 0.1), (4, 0.05)]]
    out = pgi.dask.sweep(client, runs, chunks=3)
    for r, d in zip(runs, out):
        local = r["scheme"].integrate_ensemble(X0, dt=r["dt"], t_end=1)
        assert np.array_equal(d.x, local.x, equal_nan=True) and np.array_equal(d.energy_error, local.energy_error, equal_nan=True)
    assert not np.array_equal(out[0].x, out[1].x, equal_nan=True)


def test_bad_input_is_refused_before_submitting_and_a_failing_chunk_is_named(client):
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(ValueError, match=r"X0: must have shape \(m, 3\)"):
        pgi.dask.integrate_ensemble(client, s, np.zeros((4, 2)), dt=0.1, t_end=1)
    with pytest.raises(ValueError, match="t_end: must be finite"):
        pgi.dask.integrate_ensemble(client, s, np.zeros((4, 3)), dt=0.1, t_end=-1)
    # a description the workers cannot rebuild: the error names the chunk and its rows
    bad = pgi.Scheme(**RIGID_BODY)
    bad._description = ("values", {**bad.description[1], "hamiltonian": "x1^"})
    with pytest.raises(RuntimeError, match=r"chunk 0 \(rows 0\.\.1 of X0\) failed: .*hamiltonian"):
        pgi.dask.integrate_ensemble(client, bad, np.ones((4, 3)), dt=0.1, t_end=1, chunks=2, retries=0)


# A worker that dies: the task of one chunk kills its own worker process (os._exit) the first time it runs,
# leaving a marker file so that the rerun lives. Dask's scheduler reruns the tasks of a dead worker elsewhere,
# up to distributed.scheduler.allowed-failures deaths per task (default 3); Client.submit's retries= counts
# only tasks that raise, not deaths (distributed's Scheduler.remove_worker marks a task erred, with
# KilledWorker, past allowed-failures, without looking at retries).
def fail_once(marker, first_row, how):
    """pgi.dask's task for one chunk (the one starting with first_row) failing once: how = "die" kills the
    worker process, "raise" raises OSError. Defined here, pickled by value with its closure."""
    def task(description, X0, *args):
        import os
        import pgi.dask as d
        if len(X0) and X0[0].tobytes() == first_row.tobytes() and not os.path.exists(marker):
            open(marker, "w").close()
            if how == "die":
                os._exit(1)
            raise OSError("a transient failure")
        return d._run_chunk(description, X0, *args)
    return task


def test_a_chunk_whose_worker_dies_is_rerun_and_the_result_is_the_local_one(client, tmp_path, monkeypatch):
    s = pgi.Scheme(**RIGID_BODY)
    X0 = states(16)
    local = s.integrate_ensemble(X0, dt=0.1, t_end=2, threads=1)
    marker = tmp_path / "died"
    monkeypatch.setattr(pgi.dask, "_run_chunk", fail_once(str(marker), X0[4], "die"))
    d = pgi.dask.integrate_ensemble(client, s, X0, dt=0.1, t_end=2, chunks=4, retries=0)
    assert marker.exists()  # the chunk of rows 4..7 did kill its worker once
    for f in ("x", "energy_error", "casimir_error", "status", "steps", "newton_iterations_mean"):
        assert np.array_equal(getattr(d, f), getattr(local, f), equal_nan=f not in ("status", "steps")), f
    client.wait_for_workers(2, timeout=30)  # the nanny restarts the dead worker for the tests after this one


def test_a_chunk_that_raises_once_is_retried_with_retries(client, tmp_path, monkeypatch):
    s = pgi.Scheme(**RIGID_BODY)
    X0 = states(12)
    local = s.integrate_ensemble(X0, dt=0.1, t_end=1, threads=1)
    monkeypatch.setattr(pgi.dask, "_run_chunk", fail_once(str(tmp_path / "raised"), X0[8], "raise"))
    d = pgi.dask.integrate_ensemble(client, s, X0, dt=0.1, t_end=1, chunks=4, retries=1)
    assert (tmp_path / "raised").exists()
    assert np.array_equal(d.x, local.x, equal_nan=True) and np.array_equal(d.energy_error, local.energy_error, equal_nan=True)
    monkeypatch.setattr(pgi.dask, "_run_chunk", fail_once(str(tmp_path / "raised again"), X0[8], "raise"))
    with pytest.raises(RuntimeError, match=r"chunk 2 \(rows 8\.\.11 of X0\) failed: OSError: a transient failure"):
        pgi.dask.integrate_ensemble(client, s, X0, dt=0.1, t_end=1, chunks=4, retries=0)


def test_without_reruns_a_dead_worker_names_its_chunk(tmp_path, monkeypatch):
    # a scheduler that allows no death (the setting a real one reads from DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES):
    # the chunk fails at its worker's first death, whatever retries says, and the error names it
    import dask
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None,
                                           silence_logs=50)
    with cluster, distributed.Client(cluster) as c:
        s = pgi.Scheme(**RIGID_BODY)
        X0 = states(12)
        monkeypatch.setattr(pgi.dask, "_run_chunk", fail_once(str(tmp_path / "died"), X0[4], "die"))
        with pytest.raises(RuntimeError, match=r"chunk 1 \(rows 4\.\.7 of X0\) failed: KilledWorker"):
            pgi.dask.integrate_ensemble(c, s, X0, dt=0.1, t_end=1, chunks=4, retries=2)
        assert (tmp_path / "died").exists()


def test_the_energy_warning_comes_back_per_row_and_is_said_once_on_the_client(client):
    from test_ensemble import DRIFTING
    s = pgi.Scheme(**{**RIGID_BODY, "order": 1})
    with pytest.warns(pgi.EnergyWarning, match="1 of 2 trajectories"):
        d = pgi.dask.integrate_ensemble(client, s, DRIFTING, dt=3, t_end=30, chunks=1)
    assert d.energy_warning.tolist() == [True, False]
