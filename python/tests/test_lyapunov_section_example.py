"""examples/henon_heiles_lyapunov.py, the README's figure, on a few orbits: the section's crossings are the
recording ensemble's, each coloured by its orbit's maximal exponent as Scheme.lyapunov gives it; an existing output
is refused and left as it was."""
import os
import pathlib
import subprocess
import sys

import numpy as np
import pgi
from conftest import SCENES

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "examples" / "henon_heiles_lyapunov.py"
sys.path.insert(0, str(SCRIPT.parent))
import henon_heiles_lyapunov as example  # noqa: E402


def run(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(pathlib.Path(pgi.__file__).resolve().parents[1]))  # this pgi, from any cwd
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300)


def test_the_figure_colours_each_orbits_crossings_by_its_maximal_exponent(tmp_path):
    done = run("fig.png", "--orbits", "6", "--t-end", "300", "--csv", "c.csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "fig.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=1)
    assert f"6 orbits to t = 300, {len(rows)} crossings" in done.stdout
    s = pgi.Scheme.from_toml(SCENES / "henon_heiles.toml")
    X0 = example.starts(6)
    assert np.allclose([s.hamiltonian_value(x) for x in X0], 1 / 6, rtol=0, atol=1e-15)
    e = s.integrate_ensemble(X0, dt=example.DT, t_end=300, events=[("q1", 1, False)])
    order = rows[:, 3].astype(int)
    for i in range(6):  # each orbit's crossings, in time order, and its exponent
        mine = rows[order == i]
        assert np.array_equal(mine[:, :2], e.event_x[e.event_row == i][:, [1, 3]])
        exponent = s.lyapunov(X0[i], dt=example.DT, t_end=300, every=10 ** 9).spectrum[0]
        assert (mine[:, 2] == exponent).all()
    # the crossings are on the section and keep the energy as the steps do
    assert np.abs(e.event_x[:, 0]).max() < 1e-14 and (e.event_x[:, 2] > 0).all()


def test_an_existing_output_is_refused_and_left_alone(tmp_path):
    (tmp_path / "fig.png").write_text("mine")
    done = run("fig.png", "--orbits", "2", "--t-end", "10", cwd=tmp_path)
    assert done.returncode == 2 and "exists already" in done.stderr
    assert (tmp_path / "fig.png").read_text() == "mine"
    done = run("same.png", "--csv", "./same.png", "--orbits", "2", "--t-end", "10", cwd=tmp_path)
    assert done.returncode == 2 and "cannot be one file" in done.stderr and not (tmp_path / "same.png").exists()
    done = run("out.png", "--orbits", "0", cwd=tmp_path)
    assert done.returncode == 2 and "--orbits" in done.stderr and not (tmp_path / "out.png").exists()
