"""The numeric evaluators: the vector field, pi, H, the Casimirs and the modified Hamiltonian at numpy states, from
the exact polynomials compiled once, against hand-written formulas, an RK4 of the vector field and runs of pgi."""
import numpy as np
import pytest

import pgi
from conftest import BAD_SCENES, SCENES

EPS = np.finfo(float).eps


def rigid_body_pi(x):
    """The rigid body's pi ({x1,x2} = -x3 and cyclic), by hand: shape (..., 3, 3)."""
    x1, x2, x3 = np.moveaxis(x, -1, 0)
    z = np.zeros_like(x1)
    return np.stack([np.stack([z, -x3, x2], -1), np.stack([x3, z, -x1], -1), np.stack([-x2, x1, z], -1)], -2)


def rigid_body_grad_H(x):
    """grad H for the scene's H = x1^2/4 + x2^2/2 + 3 x3^2/4."""
    return x * np.array([0.5, 1.0, 1.5])


def lotka_volterra_pi(x):
    """The cyclic Lotka-Volterra's pi ({x1,x2} = x1 x2 and cyclic), by hand."""
    x1, x2, x3 = np.moveaxis(x, -1, 0)
    z = np.zeros_like(x1)
    return np.stack([np.stack([z, x1 * x2, -x3 * x1], -1), np.stack([-x1 * x2, z, x2 * x3], -1),
                     np.stack([x3 * x1, -x2 * x3, z], -1)], -2)


def lotka_volterra_grad_H(x):
    """grad H for H = x1 + x2 + x3."""
    return np.ones_like(x)


HAND = {"rigid_body": (rigid_body_pi, rigid_body_grad_H), "lotka_volterra": (lotka_volterra_pi, lotka_volterra_grad_H)}


def states(m, n, seed=34):
    return np.random.default_rng(seed).uniform(-2, 2, (m, n))


def drift(values):
    """The largest relative deviation of values from the first."""
    return np.max(np.abs(values - values[0])) / abs(values[0])


@pytest.mark.parametrize("name", sorted(HAND))
def test_vector_field_and_pi_equal_pi_grad_H_by_hand_on_random_states(name):
    s = pgi.Scheme.from_toml(SCENES / f"{name}.toml")
    pi, grad = HAND[name]
    X = states(500, 3)
    P, F = s.poisson_matrix(X), s.vector_field(X)
    # each entry of pi is one monomial with coefficient +-1, at most one product: the same operation, the same bits
    assert np.array_equal(P, pi(X))
    assert np.array_equal(np.swapaxes(P, 1, 2), -P)
    # each component sums 3 products pi_ik dH/dx_k: both sides round each product and the sum, 4 eps of the terms'
    # magnitudes at most between them
    hand = np.einsum("mik,mk->mi", pi(X), grad(X))
    scale = np.einsum("mik,mk->mi", np.abs(pi(X)), np.abs(grad(X)))
    assert np.all(np.abs(F - hand) <= 4 * EPS * scale)
    assert F.shape == (500, 3) and s.vector_field(X[0]).shape == (3,) and s.poisson_matrix(X[0]).shape == (3, 3)


def test_one_row_alone_and_among_many_gives_the_same_bits():
    s = pgi.Scheme.from_toml(SCENES / "henon_heiles.toml")
    X = states(300, len(s.coordinates), seed=11) / 8  # past one block of rows (256) and its lanes' padding
    many = [s.vector_field(X), s.poisson_matrix(X), s.hamiltonian_value(X), s.casimir_values(X),
            s.modified_hamiltonian_value(X, 0.1, 6)]
    for j in (0, 1, 7, 8, 255, 256, 299):
        one = [s.vector_field(X[j]), s.poisson_matrix(X[j]), s.hamiltonian_value(X[j]), s.casimir_values(X[j]),
               s.modified_hamiltonian_value(X[j], 0.1, 6)]
        for a, b in zip(one, many):
            assert np.array_equal(a, b[j])
    # a list, a non-contiguous view and an int state read as the same numbers
    assert np.array_equal(s.vector_field(X[::2]), many[0][::2])
    assert np.array_equal(s.vector_field(X[3].tolist()), many[0][3])
    assert np.array_equal(s.hamiltonian_value(np.array([1, 0, 0, 1])), s.hamiltonian_value([1.0, 0.0, 0.0, 1.0]))


def rk4(f, x, t_end, steps):
    """The classical Runge-Kutta method, `steps` steps of f(t, x) from 0 to t_end."""
    h = t_end / steps
    for i in range(steps):
        t = i * h
        k1 = f(t, x)
        k2 = f(t + h / 2, x + h / 2 * k1)
        k3 = f(t + h / 2, x + h / 2 * k2)
        k4 = f(t + h, x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def test_a_fine_rk4_of_the_vector_field_agrees_with_integrate_to_the_methods_order():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")  # k = 4: method order 4
    x0 = np.array([0.6, 0.8, 0.3])
    # solve_ivp's signature; RK4 at h = 1e-3 errs by about h^4 = 1e-12, far below the method's errors at dt = 0.1, 0.05
    reference = rk4(lambda t, x: s.vector_field(x), x0, 1.0, 1000)
    errors = [np.max(np.abs(s.integrate(x0, dt=dt, t_end=1.0).x[-1] - reference)) for dt in (0.1, 0.05)]
    # order 4: halving dt divides the error by 16, to 25% (the next order's constant); a wrong field errs by O(1)
    assert errors[0] < 1e-4
    assert 12 < errors[0] / errors[1] < 20


@pytest.mark.parametrize("name", ["rigid_body", "lotka_volterra"])
def test_the_casimirs_stay_at_round_off_along_a_run(name):
    s = pgi.Scheme.from_toml(SCENES / f"{name}.toml")
    X = s.integrate(s.x0, dt=0.1, t_end=20).x
    C = s.casimir_values(X)
    assert C.shape == (len(X), 1) and s.casimir_values(X[0]).shape == (1,)
    # 200 steps, each solved to round-off (a few ulps of the Casimir per step): 200 * 4 eps < 2e-13; H, which the
    # method does not conserve, drifts far above that (an evaluator reading H would fail)
    assert drift(C[:, 0]) < 2e-13
    assert drift(s.hamiltonian_value(X)) > 1e-9


@pytest.mark.parametrize("order", [2, 4])
def test_the_modified_hamiltonian_is_conserved_better_than_H_by_the_orders_factor(order):
    s = pgi.Scheme(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"},
                   hamiltonian="x1^2/4 + x2^2/2 + 3*x3^2/4", order=order)
    p = upto = s.method_order
    dH, dHt = [], []
    for dt in (0.2, 0.1):
        X = s.integrate([0.6, 0.8, 0.3], dt=dt, t_end=10).x
        dH.append(drift(s.hamiltonian_value(X)))
        dHt.append(drift(s.modified_hamiltonian_value(X, dt, upto)))
    # H drifts like dt^p (halving dt divides it by 2^p: measured 4.00 and 16.0); H~ through dt^upto like dt^(upto+1)
    # at most (measured dt^(upto+2): the method is symmetric, H_(upto+1) = 0). 20% for the next order's constants.
    assert dH[0] / dH[1] == pytest.approx(2 ** p, rel=0.2)
    assert dHt[0] / dHt[1] > 0.8 * 2 ** (upto + 1)
    assert dHt[0] < dH[0] / 100  # measured 500x (k = 2) and 300x (k = 4) at dt = 0.2
    # through dt^0 it is H itself, bit for bit
    assert np.array_equal(s.modified_hamiltonian_value(X, 0.1, 0), s.hamiltonian_value(X))


def test_the_maps_are_compiled_once_and_the_exact_phase_runs_once():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    X = states(10, 3)
    for _ in range(3):
        s.vector_field(X), s.poisson_matrix(X[0]), s.hamiltonian_value(X), s.casimir_values(X[1])
        s.modified_hamiltonian_value(X, 0.1, 4), s.modified_hamiltonian_value(X[2], 0.05, 4)
    st = s.stats()
    # vector field, pi, (H, C) in one map, H_0..H_4; S_1..S_k and H~ computed once
    assert (st["evaluator_builds"], st["modified_builds"], st["terms_builds"]) == (4, 1, 1)


def test_a_scheme_without_casimirs_has_none_to_evaluate():
    s = pgi.Scheme(coordinates=["q", "p"], brackets={"q,p": "1"}, hamiltonian="p^2/2 + q^2/2")
    assert s.casimir_values([1.0, 2.0]).shape == (0,)
    assert s.casimir_values(states(4, 2)).shape == (4, 0)
    assert np.array_equal(s.vector_field([1.0, 2.0]), [2.0, -1.0])  # (q', p') = (p, -q)


@pytest.mark.parametrize("x, message", [
    ([1.0, 2.0], "x: must have 3 values"),
    (np.ones((2, 2)), "x: must have shape (m, 3)"),
    (np.ones((2, 3), dtype=np.float32), "x: must have dtype float64"),
    (np.ones((2, 2, 3)), "x: must have 3 values"),
    ([1.0, np.nan, 2.0], "x: must be finite"),
    (np.array([[1.0, 1.0, 1.0], [1.0, np.inf, 2.0]]), "x: row 1 is not finite"),
    ("1 2 3", "x: must be an (m, n) array of numbers, got a string"),
    ([1j, 2, 3], "x: complex values are not states"),
])
def test_bad_states_are_refused_naming_x_before_any_work(x, message):
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    for evaluate in (s.vector_field, s.poisson_matrix, s.hamiltonian_value, s.casimir_values,
                     lambda x: s.modified_hamiltonian_value(x, 0.1, 4)):
        with pytest.raises(pgi.InputError) as e:
            evaluate(x)
        assert str(e.value).startswith(message)
    assert s.stats()["terms_builds"] == 0


@pytest.mark.parametrize("kwargs, message", [
    (dict(dt=0), "dt: must be positive and finite"), (dict(dt=float("nan")), "dt: must be positive and finite"),
    (dict(dt="0.1"), "dt: must be a number"), (dict(upto=65), "upto: 65 is not a whole number from 0 to 64"),
    (dict(upto=-1), "upto: -1 is not a whole number"), (dict(upto=2.0), "upto: 2.0 is not a whole number"),
])
def test_bad_dt_and_upto_are_refused_by_name(kwargs, message):
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    with pytest.raises(pgi.InputError, match=f"^{message}"):
        s.modified_hamiltonian_value([0.6, 0.8, 0.3], **{"dt": 0.1, "upto": 4, **kwargs})


def test_the_modified_hamiltonian_takes_the_schemes_dt_and_refuses_an_invalid_scheme():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")  # dt = 1/10
    assert s.modified_hamiltonian_value([0.6, 0.8, 0.3]) == s.modified_hamiltonian_value([0.6, 0.8, 0.3], 0.1, 4)
    with pytest.raises(pgi.InputError, match="^dt: missing"):
        pgi.Scheme(coordinates=["q", "p"], brackets={"q,p": "1"}, hamiltonian="p^2/2").modified_hamiltonian_value([0.0, 1.0])
    broken = pgi.Scheme.from_toml(BAD_SCENES / "jacobi_failure.toml")
    with pytest.raises(pgi.InputError, match="Jacobi identity fails"):
        broken.modified_hamiltonian_value([1.0, 1.0, 1.0], 0.1)
    assert broken.vector_field([1.0, 2.0, 3.0]).shape == (3,)  # pi grad H needs no check
