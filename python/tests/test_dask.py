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
