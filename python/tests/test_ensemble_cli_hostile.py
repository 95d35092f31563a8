"""pgi ensemble against hostile input: no output may replace an input, special files and huge sizes are refused
before any work with a clear message and a documented exit code, and a failed trajectory never reads ok."""
import os
import subprocess

import numpy as np
import pytest

from conftest import SCENES, cli, PGI

RB = SCENES / "rigid_body.toml"
LV = SCENES / "lotka_volterra.toml"


@pytest.fixture
def states(tmp_path):
    X0 = np.random.default_rng(5).uniform(-1, 1, size=(4, 3))
    np.save(tmp_path / "run.npy", X0)
    np.savetxt(tmp_path / "run.csv", X0, delimiter=",", fmt="%.17g")
    return tmp_path


@pytest.mark.parametrize("kind", ["scene", "csv states", "a link to the states"])
def test_no_output_replaces_an_input(states, kind):
    scene = states / "s.toml"
    scene.write_bytes(RB.read_bytes())
    if kind == "scene":  # the scene s.csv and --out s: s.csv would be an output
        kept = states / "s.csv"
        kept.write_bytes(RB.read_bytes())
        args = [kept, "--states", states / "run.npy", "--out", states / "s"]
    elif kind == "csv states":  # --states run.csv --out run
        kept = states / "run.csv"
        args = [scene, "--states", kept, "--out", states / "run"]
    else:  # an output name that is a link to the states file
        kept = states / "run.npy"
        os.symlink(kept, states / "out.x.npy")
        args = [scene, "--states", kept, "--out", states / "out"]
    before = kept.read_bytes()
    code, out, err = cli("ensemble", *args, "--t-end", 1, check=False)
    assert code == 2, err
    assert "is the input file" in err
    assert kept.read_bytes() == before


def test_a_fifo_as_states_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "states.csv"
    os.mkfifo(fifo)
    p = subprocess.run([PGI, "ensemble", str(RB), "--states", str(fifo), "--t-end", "1", "--out", str(tmp_path / "r")],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "not a regular file" in p.stderr
    assert not list(tmp_path.glob("r.*"))


def test_a_link_to_a_device_as_states_is_refused(tmp_path):
    link = tmp_path / "zero.npy"
    os.symlink("/dev/zero", link)
    p = subprocess.run([PGI, "ensemble", str(RB), "--states", str(link), "--t-end", "1", "--out", str(tmp_path / "r")],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "not a regular file" in p.stderr


def test_a_huge_csv_field_is_not_echoed_whole(tmp_path):
    bad = tmp_path / "X0.csv"
    bad.write_text("1," + "9" * 5_000_000 + "x,3\n")
    code, out, err = cli("ensemble", RB, "--states", bad, "--t-end", 1, "--out", tmp_path / "r", check=False)
    assert code == 2 and "is not a number" in err
    assert len(err) < 1000 and err.count("\n") == 1


@pytest.mark.parametrize("size", [["--dt", "1e-300", "--t-end", "1e300"], ["--dt", "1e-20", "--t-end", "1e20"],
                                  ["--dt", "1e-9", "--t-end", "1"]])
def test_step_counts_past_the_budget_exit_4_before_any_work(states, size):
    code, out, err = cli("ensemble", RB, "--states", states / "run.npy", *size, "--out", states / "r", check=False)
    assert code == 4 and "above the step budget" in err
    assert not list(states.glob("r.*"))


def test_max_steps_raises_and_lowers_the_budget(states):
    code, _, err = cli("ensemble", RB, "--states", states / "run.npy", "--t-end", 1, "--max-steps", 5, "--out", states / "r",
                       check=False)
    assert code == 4 and "above the step budget of 5" in err
    cli("ensemble", RB, "--states", states / "run.npy", "--t-end", 1, "--max-steps", 10, "--out", states / "r")


@pytest.mark.parametrize("count", ["100000000", "18446744073709551615"])
def test_huge_sample_counts_exit_4_before_sampling(tmp_path, count):
    p = subprocess.run([PGI, "ensemble", str(RB), "--sample", "box", "--count", count, "--box", "-1,1", "--t-end", "1",
                        "--out", str(tmp_path / "r")], capture_output=True, text=True, timeout=60)
    assert p.returncode == 4 and "output budget" in p.stderr and "--count" in p.stderr
    assert not list(tmp_path.glob("r.*"))


def test_a_failed_first_step_is_reported_with_its_status_not_ok(states):
    # the cyclic Lotka-Volterra system through the radial realisation at dt = 2: its single run's first step fails
    X0 = np.array([[1.0, 2.0, 0.5]])
    np.save(states / "lv.npy", X0)
    single, _, single_err = cli("integrate", LV, "--realisation", "radial", "--dt", 2, "--t-end", 10, check=False)
    assert single == 3
    code, out, err = cli("ensemble", LV, "--realisation", "radial", "--dt", 2, "--t-end", 10, "--states", states / "lv.npy",
                         "--out", states / "lv", check=False)
    assert code == 3
    rows = np.genfromtxt(states / "lv.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert str(rows["status"]) != "ok" and int(rows["steps"]) == 0


def test_a_write_that_fails_leaves_every_output_of_the_set_as_it_was(tmp_path):
    """A file-size limit (ulimit -f) fails the write of the larger arrays: exit 6, and the four files are all the
    earlier run's (none replaced), never some old and some new; a fresh prefix gets none of them."""
    def run(seed, prefix, limit=None):
        def limited():
            if limit is not None:
                import resource
                resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        return subprocess.run([PGI, "ensemble", str(RB), "--sample", "box", "--count", "200", "--box", "-1,1",
                               "--seed", str(seed), "--out", str(prefix), "--t-end", "1"],
                              capture_output=True, text=True, timeout=120, preexec_fn=limited)
    first = run(1, tmp_path / "E")
    assert first.returncode == 0, first.stderr
    files = sorted(tmp_path.glob("E.*"))
    assert len(files) == 4
    before = {f.name: f.read_bytes() for f in files}
    failed = run(2, tmp_path / "E", limit=16 * 1024)
    assert failed.returncode == 6, failed.stderr
    assert "write failed" in failed.stderr
    assert {f.name: f.read_bytes() for f in sorted(tmp_path.glob("E.*"))} == before
    fresh = run(2, tmp_path / "F", limit=16 * 1024)
    assert fresh.returncode == 6, fresh.stderr
    assert not list(tmp_path.glob("F.*")) and not list(tmp_path.glob(".F.*"))
