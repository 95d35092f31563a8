"""pgi ensemble: NPY/CSV in, NPY/CSV out, equal bit for bit to the Python ensemble; bad input exits 2 before
any work with nothing written; a NaN row exits 3 with every output written; the samplers are seeded."""
import numpy as np
import pytest

import pgi
from conftest import SCENES, cli

RB = SCENES / "rigid_body.toml"


def outputs(prefix):
    return [f"{prefix}.x0.npy", f"{prefix}.x.npy", f"{prefix}.errors.npy", f"{prefix}.csv"]


def test_npy_and_csv_states_give_the_python_ensemble_bit_for_bit(tmp_path):
    X0 = np.random.default_rng(3).uniform(-1, 1, size=(17, 3))
    np.save(tmp_path / "X0.npy", X0)
    np.savetxt(tmp_path / "X0.csv", X0, delimiter=",", fmt="%.17g", header="x1,x2,x3", comments="")
    s = pgi.Scheme.from_toml(RB)
    py = s.integrate_ensemble(X0, t_end=3)
    for name, batch in (("X0.npy", []), ("X0.csv", ["--batch", 5])):
        cli("ensemble", RB, "--states", tmp_path / name, "--t-end", 3, "--threads", 2, *batch, "--out", tmp_path / name)
        assert np.array_equal(np.load(tmp_path / f"{name}.x0.npy"), X0)
        assert np.array_equal(np.load(tmp_path / f"{name}.x.npy"), py.x)
        errors = np.load(tmp_path / f"{name}.errors.npy")
        assert errors.shape == (17, 2) and np.array_equal(errors[:, 0], py.energy_error)
        assert np.array_equal(errors[:, 1], py.casimir_error[:, 0])
        rows = np.genfromtxt(tmp_path / f"{name}.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
        assert list(rows["status"]) == ["ok"] * 17 and np.array_equal(rows["x3"], py.x[:, 2])


def test_a_nan_row_exits_3_with_every_output_written(tmp_path):
    X0 = np.random.default_rng(4).uniform(-1, 1, size=(5, 3))
    X0[2, 1] = np.nan
    np.save(tmp_path / "X0.npy", X0)
    code, out, err = cli("ensemble", RB, "--states", tmp_path / "X0.npy", "--t-end", 1, "--out", tmp_path / "r", check=False)
    assert code == 3 and "1 of 5 trajectories did not reach t_end" in err and "row 2: non_finite_start" in err
    rows = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert list(rows["status"]) == ["ok", "ok", "non_finite_start", "ok", "ok"]
    x = np.load(tmp_path / "r.x.npy")
    assert np.isfinite(x[[0, 1, 3, 4]]).all() and np.isnan(x[2, 1])


def bad_npy(path, kind):
    X0 = np.ones((4, 3))
    if kind == "float32":
        np.save(path, X0.astype(np.float32))
    elif kind == "1-D":
        np.save(path, np.ones(3))
    elif kind == "fortran":
        np.save(path, np.asfortranarray(np.ones((4, 3))))
    elif kind == "columns":
        np.save(path, np.ones((4, 2)))
    elif kind == "truncated":
        np.save(path, X0)
        path.write_bytes(path.read_bytes()[:-8])
    elif kind == "not npy":
        path.write_text("x1,x2,x3\n")


@pytest.mark.parametrize("kind, message", [("float32", "dtype '<f4' is not float64"), ("1-D", "shape (3) is not 2-D"),
                                           ("fortran", "Fortran-ordered"), ("columns", "holds 2 columns, the scene has 3"),
                                           ("truncated", "needs 4 x 3 x 8 bytes of data, the file has 88"),
                                           ("not npy", "not an NPY file")])
def test_bad_npy_exits_2_before_any_work_with_nothing_written(tmp_path, kind, message):
    path = tmp_path / "X0.npy"
    bad_npy(path, kind)
    code, out, err = cli("ensemble", RB, "--states", path, "--t-end", 1, "--out", tmp_path / "r", check=False)
    assert code == 2 and message in err and str(path) in err and out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["X0.npy"]


@pytest.mark.parametrize("args, message", [
    (["--states", "{d}/X0.csv"], "X0.csv:3: field 2 'abc' is not a number"),
    (["--states", "{d}/short.csv"], "short.csv:1: expected 3 values (x1,x2,x3), got 2"),
    (["--states", "{d}/X0.txt"], "must be a .npy or .csv file"),
    (["--sample", "grid", "--count", "10", "--box", "-1,1"], "--count: 10 is not g^3"),
    (["--sample", "box", "--count", "10", "--box", "1,-1"], "--box: lo must be below hi"),
    (["--sample", "box", "--count", "10"], "--box: missing"),
    (["--sample", "box", "--count", "4", "--box", "-1,1", "--states", "{d}/X0.csv"], "excludes"),
    (["--states", "{d}/short.csv", "--x0", "1,0,0"], "--x0: is read only by --sample casimir"),
    (["--sample", "box", "--count", "4", "--box", "-1,1", "--out", "{d}/no/such/dir/r"], "does not exist"),
    ([], "give the initial states"),
    (["--sample", "box", "--count", "4", "--box", "-1,1", "--batch", "0"], "--batch"),
    (["--sample", "box", "--count", "4", "--box", "-1,1", "--batch", "2000"], "batch: 2000 is above the limit of 1024"),
])
def test_bad_options_exit_2_with_nothing_written(tmp_path, args, message):
    (tmp_path / "X0.csv").write_text("x1,x2,x3\n1,2,3\n1,abc,3\n")
    (tmp_path / "short.csv").write_text("1,2\n")
    (tmp_path / "X0.txt").write_text("1,2,3\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    argv = [a.format(d=tmp_path) for a in args]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "r")]
    code, out, err = cli("ensemble", RB, "--t-end", 1, *argv, check=False)
    assert code == 2 and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_samplers_are_seeded_and_the_casimir_one_stays_on_the_level_set(tmp_path):
    def sample(name, *args):
        cli("ensemble", RB, "--t-end", 0.5, "--out", tmp_path / name, "--sample", *args)
        return np.load(tmp_path / f"{name}.x0.npy")

    a, b, c = (sample(n, "box", "--count", 50, "--box", "-1,1", "--seed", seed) for n, seed in [("a", 5), ("b", 5), ("c", 6)])
    assert np.array_equal(a, b) and not np.array_equal(a, c) and (abs(a) <= 1).all() and a.shape == (50, 3)
    g = sample("g", "grid", "--count", 8, "--box", "0,1,2,3,4,5")
    assert g.tolist() == [[x, y, z] for x in (0, 1) for y in (2, 3) for z in (4, 5)]
    x0 = np.array(pgi.Scheme.from_toml(RB).x0)
    on = sample("k", "casimir", "--count", 40, "--box", "-1,1", "--seed", 2)
    # C(lambda y) = C(x0) to round-off: lambda = sqrt(C(x0)/C(y)) to ~1.5 u, each lambda y_i to u, the sum of
    # squares here to ~3 u: |error| < 10 u C(x0), u = 2^-53 (a wrong lambda, a missing sqrt, misses by O(1))
    u = 2.0 ** -53
    level = (x0 ** 2).sum()
    assert np.abs((on ** 2).sum(axis=1) - level).max() < 10 * u * level and np.unique(on, axis=0).shape == (40, 3)
    on2 = sample("k2", "casimir", "--count", 3, "--box", "-1,1", "--x0", "2,0,0")
    assert np.abs((on2 ** 2).sum(axis=1) - 4).max() < 10 * u * 4


@pytest.mark.parametrize("scene, message", [("henon_heiles", "needs exactly one Casimir in the scene, it has 0")])
def test_casimir_sampler_refuses_what_rescaling_cannot_reach(tmp_path, scene, message):
    code, out, err = cli("ensemble", SCENES / f"{scene}.toml", "--t-end", 1, "--out", tmp_path / "r", "--sample", "casimir",
                         "--count", 3, "--box", "-1,1", check=False)
    assert code == 2 and message in err and list(tmp_path.iterdir()) == []


def test_a_trajectory_whose_newton_fails_ends_alone_as_in_python(tmp_path):
    # x0 scaled by 40 turns 40 times faster: at dt = 0.5 its Newton iteration does not converge; the others finish
    s = pgi.Scheme.from_toml(RB)
    x0 = np.array(s.x0)
    X0 = np.array([x0, 0.5 * x0, 40 * x0, -x0])
    np.save(tmp_path / "X0.npy", X0)
    code, out, err = cli("ensemble", RB, "--states", tmp_path / "X0.npy", "--t-end", 5, "--dt", 0.5, "--out", tmp_path / "r",
                         check=False)
    assert code == 3 and "1 of 4 trajectories did not reach t_end" in err and "row 2: newton_not_converged at step 1" in err
    rows = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert list(rows["status"]) == ["ok", "ok", "newton_not_converged", "ok"]
    assert rows["failed_step"].tolist() == [0, 0, 1, 0] and rows["steps"].tolist() == [10, 10, 0, 10]
    py = s.integrate_ensemble(X0, dt=0.5, t_end=5)
    assert np.array_equal(np.load(tmp_path / "r.x.npy"), py.x) and np.array_equal(rows["residual"], py.residual)
    assert np.array_equal(np.load(tmp_path / "r.x.npy")[2], X0[2])  # the last good state: its start


@pytest.mark.parametrize("name, text", [("empty.csv", ""), ("header.csv", "x1,x2,x3\n"), ("none.npy", None)])
def test_states_without_rows_exit_2_with_nothing_written(tmp_path, name, text):
    path = tmp_path / name
    if text is None:
        np.save(path, np.zeros((0, 3)))
    else:
        path.write_text(text)
    code, out, err = cli("ensemble", RB, "--states", path, "--t-end", 1, "--out", tmp_path / "r", check=False)
    assert code == 2 and f"{path}: holds no states (no rows): nothing to integrate" in err and out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_energy_drift_past_a_tenth_is_said_on_stderr_in_json_and_per_row_in_the_csv(tmp_path):
    from test_ensemble import DRIFTING
    np.save(tmp_path / "X0.npy", DRIFTING)
    code, out, err = cli("ensemble", RB, "--order", 1, "--dt", 3, "--states", tmp_path / "X0.npy", "--t-end", 30,
                         "--out", tmp_path / "r", "--json", check=False)
    assert code == 0 and "warning: 1 of 2 trajectories reached a relative energy error above 0.1" in err
    import json
    assert json.loads(out)["energy_warnings"] == 1
    rows = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert rows["energy_warning"].tolist() == [1, 0]
