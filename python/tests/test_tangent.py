"""The step's tangent map, a run's tangent map and Lyapunov exponents (Scheme.step_jacobian, integrate(tangent=True),
Scheme.lyapunov, pgi lyapunov): against central differences, the Poisson identities, the two-particle method, and
bad input."""
import numpy as np
import pytest

import pgi
from conftest import SCENES, cli, cli_json


def central_differences(s, x, dt, h=1e-5):
    """d step / dx by central differences: truncation ~ h^2, round-off ~ u / h, both near 1e-10."""
    n = len(x)
    h = h * max(1.0, np.abs(x).max())
    fd = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        fd[:, j] = (s.step(x + e, dt) - s.step(x - e, dt)) / (2 * h)
    return fd


def test_step_jacobian_equals_central_differences_and_is_poisson(scene):
    s = pgi.Scheme.from_toml(scene)
    x = np.asarray(s.x0) if s.x0 is not None else np.linspace(0.5, 1.5, len(s.coordinates))  # in every domain
    J = s.step_jacobian(x)
    assert J.shape == (len(x), len(x))
    assert np.abs(J - central_differences(s, x, s.dt)).max() <= 1e-7 * np.abs(J).max()
    # J pi(x) J^T = pi(step(x)) to round-off
    y = s.step(x)
    defect = J @ s.poisson_matrix(x) @ J.T - s.poisson_matrix(y)
    assert np.abs(defect).max() <= 1e-12 * np.abs(s.poisson_matrix(x)).max() * np.abs(J).max() ** 2


def test_a_runs_jacobian_is_the_product_of_its_steps_jacobians():
    s = pgi.Scheme.from_toml(SCENES / "lotka_volterra.toml")
    r = s.integrate(dt=s.dt, t_end=40 * s.dt, tangent=True)
    assert r.jacobian.shape == (3, 3)
    product = np.eye(3)
    for x in r.x[:-1]:
        product = s.step_jacobian(x) @ product
    assert np.abs(r.jacobian - product).max() <= 1e-13 * np.abs(product).max()
    assert not hasattr(s.integrate(dt=s.dt, t_end=1.0), "jacobian")  # only when asked


# Henon-Heiles at E = 1/6 (q1 = 0 on the section, p1 from the energy): a chaotic orbit and a regular one.
HH = SCENES / "henon_heiles.toml"


def on_energy_sixth(q2, p2):
    """(0, q2, p1, p2) with H = 1/6, p1 > 0."""
    p1 = np.sqrt(2 * (1 / 6 - q2 ** 2 / 2 + q2 ** 3 / 3) - p2 ** 2)
    return np.array([0.0, q2, p1, p2])


CHAOTIC, REGULAR = on_energy_sixth(-0.25, 0.0), on_energy_sixth(0.1, 0.0)
T, DT = 2000.0, 0.1


def two_particle(s, x, t_end, every=10.0, d0=1e-8):
    """The maximal exponent from the separation of two nearby orbits, both integrated by pgi, renormalised to d0
    every `every` time units (Benettin's two-particle method)."""
    v = np.ones(len(x)) / np.sqrt(len(x))
    y, total = x + d0 * v, 0.0
    for _ in range(int(round(t_end / every))):
        x = s.integrate(x, dt=DT, t_end=every).x[-1]
        y = s.integrate(y, dt=DT, t_end=every).x[-1]
        d = np.linalg.norm(y - x)
        total += np.log(d / d0)
        y = x + (y - x) * (d0 / d)
    return total / t_end


def test_henon_heiles_exponents_separate_chaos_from_order_and_match_the_two_particle_method():
    s = pgi.Scheme.from_toml(HH)
    chaotic = s.lyapunov(CHAOTIC, dt=DT, t_end=T, every=1000)
    regular = s.lyapunov(REGULAR, dt=DT, t_end=T, every=1000)
    estimate = two_particle(s, CHAOTIC, T)
    assert estimate > 0.01
    assert abs(chaotic.spectrum[0] - estimate) <= 0.2 * estimate
    assert regular.spectrum.max() < 0.1 * chaotic.spectrum[0]
    for r in (chaotic, regular):
        assert abs(r.spectrum.sum()) < 1e-8
        assert r.exponents.shape == (len(r.t), 4)
        assert r.t[-1] == pytest.approx(T)
        assert (r.spectrum == r.exponents[-1]).all()


def test_lyapunov_on_the_rigid_body_reports_the_casimirs_direction_as_zero():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    r = s.lyapunov([0.01, 0.99, 0.01], dt=0.1, t_end=100.0, every=100)
    assert r.leaf_dim == 2
    assert r.spectrum[2] == 0.0
    assert abs(r.spectrum[0] + r.spectrum[1]) <= 1e-12


def test_pgi_lyapunov_equals_the_python_method():
    j = cli_json("lyapunov", HH, "--t-end", "50", "--every", "100")
    r = pgi.Scheme.from_toml(HH).lyapunov(dt=0.1, t_end=50, every=100)
    assert j["spectrum"] == r.spectrum.tolist()
    assert j["t"] == r.t.tolist()
    code, out, err = cli("lyapunov", HH, "--every", "0", check=False)
    assert code == 2 and "--every" in err


@pytest.mark.parametrize("call, name", [
    (lambda s: s.step_jacobian([1.0, 2.0]), "x"),
    (lambda s: s.step_jacobian([1.0, np.nan, 0.0]), "x"),
    (lambda s: s.step_jacobian([1.0, 2.0, 0.0], dt=-1.0), "dt"),
    (lambda s: s.step_jacobian([1.0, 2.0, 0.0], dt=np.inf), "dt"),
    (lambda s: s.integrate(tangent=1), "tangent"),
    (lambda s: s.integrate(events=[("x1", 0, True)], tangent=True), "tangent"),
    (lambda s: s.lyapunov([[1.0, 2.0, 0.5]]), "x0"),
    (lambda s: s.lyapunov([1.0, np.inf, 0.5]), "x0"),
    (lambda s: s.lyapunov(every=0), "every"),
    (lambda s: s.lyapunov(t_end=-1.0), "t_end"),
    (lambda s: s.lyapunov(t_end=0.0), "t_end"),
    (lambda s: s.lyapunov(dt=0.0), "dt"),
    (lambda s: s.lyapunov(max_steps=10, t_end=100.0), "steps"),
])
def test_bad_input_is_refused_naming_the_argument(call, name):
    s = pgi.Scheme.from_toml(SCENES / "lotka_volterra.toml")
    with pytest.raises((pgi.InputError, pgi.ResourceLimitError), match=name):
        call(s)
