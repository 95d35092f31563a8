"""Parameters: symbols of the exact phase given values at run time. A run (one, a sweep in one ensemble, an evaluator)
with values w equals the scheme with w written into H, to round-off; the exact phase is built once."""
from fractions import Fraction

import numpy as np
import pytest

import pgi
from conftest import SCENES

X0 = np.array([0.4535961214255773, 0.0, 0.8912073600614354])
BRACKETS = {"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"}


def rigid_body(w=None, **kw):
    """The rigid body with inverse moments of inertia w1..w3: parameters (w None), or the exact values w written in."""
    if w is None:
        return pgi.Scheme(["x1", "x2", "x3"], BRACKETS, "1/2*w1*x1^2 + 1/2*w2*x2^2 + 1/2*w3*x3^2",
                          ["x1^2 + x2^2 + x3^2"], order=4, dt=0.1, parameters={"w1": "1/2", "w2": 1, "w3": "1.5"}, **kw)
    a, b, c = (f"({v})" for v in w)
    return pgi.Scheme(["x1", "x2", "x3"], BRACKETS, f"1/2*{a}*x1^2 + 1/2*{b}*x2^2 + 1/2*{c}*x3^2",
                      ["x1^2 + x2^2 + x3^2"], order=4, dt=0.1)


def relative(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def test_parameters_and_their_exact_defaults():
    s = rigid_body()
    assert s.parameters == {"w1": "1/2", "w2": "1", "w3": "3/2"}
    assert s.coordinates == ["x1", "x2", "x3"]
    assert pgi.Scheme(["q", "p"], {"q,p": "1"}, "p^2/2 + k*q^2/2", parameters={"k": "0.05"}).parameters == {"k": "1/20"}
    scene = pgi.Scheme.from_toml(SCENES / "rigid_body_parameters.toml")
    assert scene.parameters == {"w1": "1/2", "w2": "1", "w3": "3/2"}
    assert scene.realisation == "lie-poisson" and scene.check()["ok"]


def test_terms_are_polynomials_in_coordinates_and_parameters():
    s = rigid_body()
    S = s.terms()
    assert "w1" in S[2] and "w3" in S[2]
    sympy = pytest.importorskip("sympy")
    sym = s.terms_sympy()
    assert sympy.Symbol("w2") in sym[2].free_symbols


def test_a_run_with_values_equals_the_scheme_with_the_values_written_in():
    s = rigid_body()
    for w in [("1/2", "1", "3/2"), ("2/5", "7/10", "9/4"), ("-1/2", "3", "1/7")]:
        values = {f"w{i + 1}": float(Fraction(v)) for i, v in enumerate(w)}
        got = s.integrate(X0, t_end=5, parameters=values).x[-1]
        assert relative(got, rigid_body(w).integrate(X0, t_end=5).x[-1]) < 1e-13
        assert relative(s.step(X0, parameters=values), rigid_body(w).step(X0)) < 1e-14
    assert s.stats()["terms_builds"] == 1


def test_tangent_maps_and_lyapunov_exponents_take_values_as_the_scheme_with_them_written_in():
    s = rigid_body()
    x = np.array([0.3, 0.9, -0.2])
    for w in [("2/5", "7/10", "9/4"), ("1/2", "1", "3/2")]:
        values = {f"w{i + 1}": float(Fraction(v)) for i, v in enumerate(w)}
        fixed = rigid_body(w)
        assert relative(s.step_jacobian(x, parameters=values), fixed.step_jacobian(x)) < 1e-13
        got = s.lyapunov(x, t_end=50, every=100, parameters=values)
        want = fixed.lyapunov(x, t_end=50, every=100)
        assert np.abs(got.spectrum - want.spectrum).max() < 1e-11 and got.spectrum[2] == 0.0
    other = s.lyapunov(x, t_end=50, every=100, parameters={"w1": 0.4, "w2": 0.7, "w3": 2.25}).spectrum
    assert np.abs(other - s.lyapunov(x, t_end=50, every=100).spectrum).max() > 1e-3  # the values are used
    with pytest.raises(pgi.InputError, match="unknown parameter 'I1'"):
        s.lyapunov(x, t_end=1, parameters={"I1": 2.0})
    assert s.stats()["terms_builds"] == 1


def test_the_command_line_lyapunov_takes_param():
    from conftest import cli_json
    scene = SCENES / "rigid_body_parameters.toml"
    j = cli_json("lyapunov", scene, "--param", "w1=0.4", "--t-end", "20", "--every", "50")
    want = pgi.Scheme.from_toml(scene).lyapunov(t_end=20, every=50, parameters={"w1": 0.4})
    assert j["spectrum"] == want.spectrum.tolist()


def test_an_ensemble_sweeps_one_value_per_trajectory():
    s = rigid_body()
    m = 200
    w1 = [Fraction(20 + j, 40) for j in range(m)]
    w3 = [Fraction(60 + j, 50) for j in range(m)]
    r = s.integrate_ensemble(np.tile(X0, (m, 1)), t_end=5,
                             parameters={"w1": np.array([float(v) for v in w1]), "w3": [float(v) for v in w3]})
    assert list(r.status) == ["ok"] * m
    assert r.x.shape == (m, 3)
    for j in range(0, m, 37):
        expected = rigid_body((w1[j], 1, w3[j])).integrate(X0, t_end=5).x[-1]
        assert relative(r.x[j], expected) < 1e-13
    assert np.max(r.casimir_error) < 1e-14
    assert s.stats()["terms_builds"] == 1


def test_a_parameterised_casimir_stays_at_round_off():
    s = pgi.Scheme(["x1", "x2", "x3"], BRACKETS, "1/2*w1*x1^2 + 1/2*w2*x2^2 + 1/2*w3*x3^2",
                   ["w1*(x1^2 + x2^2 + x3^2) + w2*w3"], order=4, dt=0.1, parameters={"w1": 1, "w2": 2, "w3": 3})
    r = s.integrate(X0, t_end=100, parameters={"w1": 3.0, "w3": 0.7})
    assert r.casimir_error_max[0] < 1e-14


def test_evaluators_take_values_per_row():
    s = rigid_body()
    X = np.array([[0.3, -0.4, 0.5], [1.0, 2.0, -1.0]])
    H = s.hamiltonian_value(X, parameters={"w1": [2.0, 4.0]})
    assert H[0] == pytest.approx(0.5 * 2.0 * 0.09 + 0.5 * 0.16 + 0.75 * 0.25, rel=1e-15)
    assert H[1] == pytest.approx(0.5 * 4.0 + 0.5 * 4.0 + 0.75, rel=1e-15)
    F = s.vector_field(X[0], parameters={"w1": 2.0})
    assert relative(F, rigid_body(("2", "1", "3/2")).vector_field(X[0])) < 1e-15
    Ht = s.modified_hamiltonian_value(X, parameters={"w2": 3.0})
    assert relative(Ht, rigid_body(("1/2", "3", "3/2")).modified_hamiltonian_value(X)) < 1e-14


def test_bad_parameters_are_refused_naming_them():
    s = rigid_body()
    with pytest.raises(pgi.InputError, match=r"parameters: unknown parameter 'I1' \(the scheme's parameters: w1, w2, w3\)"):
        s.integrate(X0, t_end=1, parameters={"I1": 2.0})
    with pytest.raises(pgi.InputError, match="parameters.w1: its value at row 0 is not finite"):
        s.integrate(X0, t_end=1, parameters={"w1": float("nan")})
    with pytest.raises(pgi.InputError, match="parameters.w2: has 3 values, for 2 trajectories"):
        s.integrate_ensemble(np.tile(X0, (2, 1)), t_end=1, parameters={"w2": [1.0, 2.0, 3.0]})
    with pytest.raises(pgi.InputError, match="parameters.w3: must be a number or a 1-D array"):
        s.integrate_ensemble(np.tile(X0, (2, 1)), t_end=1, parameters={"w3": [[1.0], [2.0]]})
    with pytest.raises(pgi.InputError, match="parameters.w3: must be a number"):
        s.step(X0, parameters={"w3": "fast"})
    with pytest.raises(pgi.InputError, match=r"brackets.\"x1,x2\": uses the parameter 'w1'"):
        pgi.Scheme(["x1", "x2", "x3"], dict(BRACKETS, **{"x1,x2": "-w1*x3"}), "x1^2", parameters={"w1": 1})
    with pytest.raises(pgi.InputError, match="parameters.x2: 'x2' is also a coordinate"):
        pgi.Scheme(["x1", "x2", "x3"], BRACKETS, "x1^2", parameters={"x2": 1})
    with pytest.raises(pgi.InputError, match="parameters.k: "):
        pgi.Scheme(["q", "p"], {"q,p": "1"}, "p^2", parameters={"k": "one"})
    with pytest.raises(pgi.InputError, match="unknown parameter 'w1' \\(the scheme's parameters: none\\)"):
        rigid_body(("1", "1", "1")).integrate(X0, t_end=1, parameters={"w1": 1.0})


def test_a_pickled_scheme_keeps_its_parameters():
    import pickle
    s = pickle.loads(pickle.dumps(rigid_body()))
    assert s.parameters == {"w1": "1/2", "w2": "1", "w3": "3/2"}


def test_the_command_line_takes_param_and_a_parameter_file(tmp_path):
    from conftest import cli, cli_json
    scene = SCENES / "rigid_body_parameters.toml"
    c = cli_json("check", scene)
    assert c["coordinates"] == ["x1", "x2", "x3"] and c["parameters"] == {"w1": "1/2", "w2": "1", "w3": "3/2"}
    assert "parameters: w1 = 1/2, w2 = 1, w3 = 3/2" in cli("check", scene)[1]
    for command in ("terms", "modified"):  # the exact reports: polynomials in the coordinates and the parameters
        j = cli_json(command, scene, "--order", "2")
        assert j["coordinates"] == ["x1", "x2", "x3"] and j["parameters"] == {"w1": "1/2", "w2": "1", "w3": "3/2"}
    j = cli_json("realisation", scene, "--degree", "2")  # alpha and beta of the coordinates (a parameter's: itself)
    assert j["coordinates"] == ["x1", "x2", "x3"] and j["parameters"] == {"w1": "1/2", "w2": "1", "w3": "3/2"}
    assert len(j["alpha"]) == len(j["beta"]) == len(j["momenta"]) == 3 and "w1" not in "".join(j["alpha"])
    assert "w1" in cli_json("terms", scene, "--order", "2")["S"][0]
    assert "parameters" not in cli_json("terms", SCENES / "rigid_body.toml", "--order", "2")
    j = cli_json("integrate", scene, "--param", "w1=0.4", "--param", "w3=2/3", "--t-end", "5")
    assert j["parameters"] == {"w1": 0.4, "w2": 1.0, "w3": 2 / 3}
    r = pgi.Scheme.from_toml(scene).integrate(t_end=5, parameters={"w1": 0.4, "w3": 2 / 3})
    assert r.x[-1].tolist() == j["x"]  # the same step, built at the same extended x0
    code, _, err = cli("integrate", scene, "--param", "I1=2", check=False)
    assert code == 2 and "--param: unknown parameter 'I1' (the scene's parameters: w1, w2, w3)" in err
    code, _, err = cli("integrate", scene, "--param", "w1", check=False)
    assert code == 2 and "--param: 'w1' is not NAME=VALUE" in err
    states, params = tmp_path / "x0.npy", tmp_path / "w.npy"
    np.save(states, np.tile(X0, (3, 1)))
    W = np.array([[0.4, 1.0, 1.5], [0.5, 1.0, 1.5], [0.6, 2.0, 1.0]])
    np.save(params, W)
    cli("ensemble", scene, "--states", states, "--params", params, "--t-end", "5", "--out", tmp_path / "e")
    got = np.load(tmp_path / "e.x.npy")
    local = pgi.Scheme.from_toml(scene).integrate_ensemble(np.tile(X0, (3, 1)), t_end=5,
                                                           parameters={f"w{a + 1}": W[:, a] for a in range(3)})
    assert got.tolist() == local.x.tolist()
    np.save(params, W[:2])
    code, _, err = cli("ensemble", scene, "--states", states, "--params", params, "--t-end", "5", "--out",
                       tmp_path / "f", check=False)
    assert code == 2 and "holds 2 rows of parameters for 3 states" in err


def test_dask_chunks_get_their_rows_parameter_values():
    import pgi.dask
    s = rigid_body()
    states = np.tile(X0, (4, 1))
    _, _, rows = pgi.dask._Job.check(s, states, None, 1.0, None, None, {"w1": [0.1, 0.2, 0.3, 0.4], "w2": 2.0})
    assert rows(1, 3)["w1"].tolist() == [0.2, 0.3] and rows(1, 3)["w2"].tolist() == [2.0]
    with pytest.raises(pgi.InputError, match="parameters.w1: has 3 values, for 4 trajectories"):
        pgi.dask._Job.check(s, states, None, 1.0, None, None, {"w1": [0.1, 0.2, 0.3]})
    with pytest.raises(pgi.InputError, match="unknown parameter 'I1'"):
        pgi.dask._Job.check(s, states, None, 1.0, None, None, {"I1": 1.0})
