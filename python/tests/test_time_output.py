"""Output at requested times (integrate(t_eval=...)): rows at exactly those times, each a true partial step of the
method from the run's state before it (no interpolant), the run itself unchanged, the Casimirs kept to round-off,
and bad times refused before any work."""
import csv

import numpy as np
import pytest

import pgi
from conftest import SCENES, cli


def rigid_body():
    return pgi.Scheme.from_toml(f"{SCENES}/rigid_body.toml")


def test_rows_are_at_the_requested_times_and_the_run_is_unchanged():
    s = rigid_body()
    dt, t_end = s.dt, 100 * s.dt
    plain = s.integrate(dt=dt, t_end=t_end, tangent=True)
    times = np.array([0.0, 0.3 * dt, 5 * dt, 12.75 * dt, t_end])
    r = s.integrate(dt=dt, t_end=t_end, t_eval=times, tangent=True)
    assert np.array_equal(r.t, times)
    assert r.x.shape == (len(times), 3)
    assert np.array_equal(r.x[0], plain.x[0]) and np.array_equal(r.x[2], plain.x[5])
    assert np.array_equal(r.x[-1], plain.x[-1])  # the same steps, bit for bit
    assert np.array_equal(r.jacobian, plain.jacobian)


def test_a_row_between_steps_is_one_step_of_the_remaining_time():
    s = rigid_body()
    dt = s.dt
    plain = s.integrate(dt=dt, t_end=20 * dt)
    r = s.integrate(dt=dt, t_end=20 * dt, t_eval=[12.75 * dt])
    # one step of 0.75 dt from the state at 12 dt; step() builds its own compiled step (its predictor chosen for
    # 0.75 dt), whose Newton solution may differ within the acceptance test's 64 u
    expected = s.step(plain.x[12], 0.75 * dt)
    assert np.abs(r.x[0] - expected).max() <= 64 * np.finfo(float).eps * np.abs(expected).max()
    # and it is not the state at either end of that step
    assert np.abs(r.x[0] - plain.x[12]).max() > 1e-3 and np.abs(r.x[0] - plain.x[13]).max() > 1e-4


def test_rows_between_steps_keep_the_casimir():
    s = rigid_body()
    dt = s.dt
    times = (np.arange(300) * 3.3 + 0.41) * dt
    r = s.integrate(dt=dt, t_end=1000 * dt, t_eval=times)
    C = (r.x ** 2).sum(axis=1)  # x1^2 + x2^2 + x3^2
    C0 = (np.asarray(s.x0) ** 2).sum()
    # a round-off random walk over at most 1000 steps and one more: ~u sqrt(1000) = 3.5e-15; 2e-14 holds it
    assert np.abs(C - C0).max() <= 2e-14 * C0
    assert r.casimir_error.max() <= 2e-14


@pytest.mark.parametrize("times, says", [([0.5, 0.2], "increase strictly"), ([-1.0], "outside [0, t_end"),
                                         ([float("nan")], "not finite"), ([[0.1, 0.2]], "1-d array"),
                                         (["a"], "t_eval"), ([2.0], "outside [0, t_end"), ([], "is empty")])
def test_bad_times_are_refused_naming_t_eval(times, says):
    s = rigid_body()
    with pytest.raises(pgi.InputError) as e:
        s.integrate(dt=s.dt, t_end=1.0, t_eval=times)
    assert "t_eval" in str(e.value) and says in str(e.value)


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array([[float(v) for v in row] for row in rows[1:]])


def test_the_command_line_writes_rows_at_the_requested_times(tmp_path):
    s = rigid_body()
    dt = s.dt
    times = [0.0, 0.25, 1.0, 3.3, 10.0]
    out = tmp_path / "at.csv"
    cli("integrate", f"{SCENES}/rigid_body.toml", "--t-end", "10", "--csv", out, "--t-eval", ",".join(map(str, times)))
    header, rows = read_csv(out)
    assert header[0] == "t" and np.array_equal(rows[:, 0], times)
    r = s.integrate(dt=dt, t_end=10, t_eval=times)
    assert np.array_equal(rows[:, 1:4], r.x)  # the shortest decimals that read back: the same bits
    # a file of times, one per line, gives the same rows
    listed = tmp_path / "times.txt"
    listed.write_text("\n".join(map(str, times)) + "\n")
    again = tmp_path / "again.csv"
    cli("integrate", f"{SCENES}/rigid_body.toml", "--t-end", "10", "--csv", again, "--t-eval", listed)
    assert again.read_text() == out.read_text()


@pytest.mark.parametrize("extra, says", [(["--t-eval", "0.5,0.2"], "increase strictly"),
                                         (["--t-eval", "0.5,x"], "item 2 'x' is not a finite number"),
                                         (["--t-eval", "11"], "outside [0, t_end"),
                                         (["--t-eval", "no-such-file"], "no-such-file"),
                                         (["--t-eval", ""], "--t-eval: no times given"),
                                         (["--t-eval", "1e400"], "item 1 '1e400' is not a finite number"),
                                         (["--t-eval", "."], "is a directory"),
                                         (["--t-eval", "1", "--every", "2"], "excludes")])
def test_the_command_line_refuses_bad_times_with_exit_2(tmp_path, extra, says):
    out = tmp_path / "x.csv"
    code, stdout, stderr = cli("integrate", f"{SCENES}/rigid_body.toml", "--t-end", "10", "--csv", out, *extra,
                               check=False)
    assert code == 2 and says in stderr and not out.exists()


def test_the_command_line_needs_a_csv_for_t_eval():
    code, _, stderr = cli("integrate", f"{SCENES}/rigid_body.toml", "--t-eval", "1", check=False)
    assert code == 2 and "--csv" in stderr
