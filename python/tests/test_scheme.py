"""The Python module against the command line: same numbers bit for bit, same exact terms, same errors."""
import pickle
import threading

import numpy as np
import pytest

import pgi
from conftest import BAD_SCENES, SCENES, cli, cli_json

RIGID_BODY = dict(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"},
                  hamiltonian="1/4*x1^2 + 1/2*x2^2 + 3/4*x3^2", casimirs=["x1^2 + x2^2 + x3^2"], order=4)


def has_run(s):
    return s.x0 is not None and s.t_end is not None


def test_integrate_equals_the_command_line_bit_for_bit(scene):
    s = pgi.Scheme.from_toml(scene)
    if not has_run(s):
        pytest.skip("no [run]")
    r = s.integrate()
    j = cli_json("integrate", scene)
    assert r.steps == j["steps"]
    assert r.t[-1] == j["t"]
    assert r.x[-1].tolist() == j["x"]  # exact equality: the same stepper, the same summation
    assert r.energy_error_max == j["energy_error_max"]
    assert r.casimir_error_max == j["casimir_error_max"]
    assert r.newton_iterations_mean == j["newton_iterations_mean"]
    assert s.order == j["order"] and s.method_order == j["method_order"]
    # the recorded rows: t = n dt, the first the initial state with zero errors
    assert r.x.shape == (r.steps + 1, len(s.coordinates)) and r.t.shape == (r.steps + 1,)
    assert r.x[0].tolist() == list(s.x0) and r.energy_error[0] == 0.0
    assert r.energy_error.max() == r.energy_error_max


def test_step_equals_the_command_line_bit_for_bit(scene):
    s = pgi.Scheme.from_toml(scene)
    if s.x0 is None:
        pytest.skip("no x0")
    x = s.step(s.x0)
    assert isinstance(x, np.ndarray) and x.tolist() == cli_json("step", scene)["x"]


def test_exact_terms_equal_the_command_line(scene):
    s = pgi.Scheme.from_toml(scene)
    assert s.terms() == cli_json("terms", scene)["S"]
    assert s.modified_hamiltonian(3) == cli_json("modified", scene, "--upto", 3)["modified"]
    assert len(s.terms(latex=True)) == s.order
    c, j = s.check(), cli_json("check", scene)
    assert c["ok"] == j["ok"] and c["class"] == j["class"] and c["jacobi"] == j["jacobi"]
    assert c["casimirs"] == j["casimirs"] and c["realisation"] == j["realisation"]


def test_from_values_equals_the_scene():
    s, t = pgi.Scheme(**RIGID_BODY), pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    assert s.terms() == t.terms()
    assert s.modified_hamiltonian(2) == t.modified_hamiltonian(2)
    assert s.realisation == "lie-poisson" and s.structure_class == "linear" and s.method_order == 4
    x0 = np.array(t.x0)
    r, q = s.integrate(x0, dt=0.1, t_end=10, every=10), t.integrate(t_end=10)
    assert r.x[-1].tolist() == q.x[-1].tolist()
    assert r.t.tolist() == [n * 0.1 for n in range(0, 101, 10)]  # t = n dt, as the command line computes it
    assert r.casimir_error.shape == (11, 1) and r.casimir_error_max[0] < 1e-14


def test_sympy_conversion():
    sympy = pytest.importorskip("sympy")
    s = pgi.Scheme(**RIGID_BODY)
    x1, x2, x3 = sympy.symbols("x1 x2 x3")
    S = s.terms_sympy()
    assert sympy.expand(S[0] - (x1**2 / 4 + x2**2 / 2 + 3 * x3**2 / 4)) == 0
    # the same polynomials: sympy's expansion of pgi's text equals pgi's own second term
    assert sympy.expand(S[2]) == sympy.sympify(s.terms()[2].replace("^", "**"))


def test_bad_values_raise_value_errors_naming_the_entry():
    bad = [dict(brackets={"x1,q": "x3"}, key="brackets.\"x1,q\""),
           dict(brackets={"x1,x2": "-x3", "x2,x1": "-x3"}, key="contradicts"),
           dict(hamiltonian="x1^", key="hamiltonian.H"),
           dict(casimirs=["y"], key="hamiltonian.casimirs[0]"),
           dict(coordinates=["x1", "x1", "x3"], key="coordinates[1]"),
           dict(order=0, key="order"),
           dict(realisation="exact", key="realisation"),
           dict(dt=-1.0, key="dt"),
           dict(x0=[1.0, 2.0], key="x0")]
    for b in bad:
        key = b.pop("key")
        with pytest.raises(ValueError, match=None) as e:
            pgi.Scheme(**{**RIGID_BODY, **b})
        assert key in str(e.value), (b, str(e.value))
        assert isinstance(e.value, pgi.InputError)
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(ValueError, match="x0"):
        s.integrate()  # no x0 given anywhere
    with pytest.raises(ValueError, match="must have 3 values"):
        s.step([1.0, 2.0], 0.1)
    with pytest.raises(ValueError, match="brackets"):
        pgi.Scheme(**{**RIGID_BODY, "brackets": {"x1,x2": 3}})


def test_bad_scenes_raise_with_the_command_lines_message():
    for path in sorted(BAD_SCENES.glob("*.toml")):
        code, _, err = cli("terms", path, check=False)
        assert code != 0, path
        with pytest.raises((ValueError, pgi.ResourceLimitError)) as e:
            s = pgi.Scheme.from_toml(path)
            s.require_valid()
        assert str(e.value) in err, (path, str(e.value), err)


def test_a_failed_step_raises_step_failure_with_step_t_and_residual():
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    code, _, err = cli("integrate", SCENES / "rigid_body.toml", "--dt", 5, "--order", 2, check=False)
    assert code == 3
    t = pgi.Scheme(**{**RIGID_BODY, "order": 2})
    with pytest.raises(pgi.StepFailure) as e:
        t.integrate(s.x0, dt=5.0, t_end=100)
    f = e.value
    assert f.step >= 1 and f.t == (f.step - 1) * 5.0 and f.residual > 0 or not np.isfinite(f.residual)
    assert str(f) in err  # the command line's message
    assert f.result.steps == f.step - 1 and len(f.result.t) == f.step


def test_integrations_run_in_parallel_threads_with_the_same_result():
    s = pgi.Scheme.from_toml(SCENES / "lotka_volterra.toml")
    results = [None] * 4

    def run(i):
        results[i] = s.integrate(every=100)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for r in results[1:]:
        assert r.x.tolist() == results[0].x.tolist()


def test_version():
    assert pgi.__version__.count(".") == 2
    assert cli("--version")[1].split()[:2] == ["pgi", pgi.__version__]


def test_a_non_finite_invariant_ends_the_run_as_on_the_command_line():
    # one run loop (scheme/run_loop) for Python, the command line and ensembles: H = inf at x0 stops all three
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    code, _, err = cli("integrate", SCENES / "rigid_body.toml", "--x0", "1e200,0,0", check=False)
    assert code == 3
    with pytest.raises(pgi.StepFailure) as e:
        s.integrate([1e200, 0.0, 0.0], t_end=1)
    assert str(e.value) == "the invariant H = inf at x0 is not finite: nothing to integrate" and str(e.value) in err
    assert e.value.step == 0 and e.value.result.steps == 0 and len(e.value.result.t) == 0
    r = s.integrate_ensemble(np.array([[1e200, 0.0, 0.0], s.x0]), t_end=1)
    assert r.status.tolist() == ["non_finite", "ok"] and r.steps.tolist() == [0, 10] and r.failed_step[0] == 0


def test_a_dt_whose_powers_overflow_fails_as_a_step_on_every_surface():
    # S_dt's coefficients at dt = 1e300 are past the double range: the step overflows, as at run time, and fails
    # with its step, not with the build's message about a coefficient
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    with pytest.raises(pgi.StepFailure, match="step 1 "):
        s.step([0.6, 0.8, 0.3], 1e300)
    code, _, err = cli("integrate", SCENES / "henon_heiles.toml", "--dt", "1e200", "--t-end", "1e200", check=False)
    assert code == 3 and "step 1 (from t = 0) failed" in err and "coefficient" not in err


def test_trust_jacobi_skips_the_check_as_the_command_line_does_and_survives_pickling():
    # {x_i, x_j} = eps_ijk v_k with v = (-x2, x1, 1): Jacobi needs v . curl v = 0, here it is 2
    broken = dict(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "1", "x2,x3": "-x2", "x3,x1": "x1"},
                  hamiltonian="x1^2/2 + x2^2/2 + x3^2/2")
    assert pgi.Scheme(**broken).check()["jacobi"]["holds"] is False
    trusted = pgi.Scheme(**broken, trust_jacobi=True)
    assert trusted.jacobi_trusted and trusted.check()["jacobi"] == {"holds": None, "skipped": "trust_jacobi"}
    assert pickle.loads(pickle.dumps(trusted)).jacobi_trusted
    scene = pgi.Scheme.from_toml(SCENES / "rigid_body.toml", trust_jacobi=True)
    assert scene.jacobi_trusted and scene.check()["jacobi"]["holds"] is None
    assert pickle.loads(pickle.dumps(scene)).jacobi_trusted
    assert cli_json("check", SCENES / "rigid_body.toml", "--trust-jacobi")["jacobi"]["holds"] is None
    assert not pgi.Scheme.from_toml(SCENES / "rigid_body.toml").jacobi_trusted
    for flag in (1, "yes", None):
        with pytest.raises(ValueError, match="trust_jacobi: must be True or False"):
            pgi.Scheme(**RIGID_BODY, trust_jacobi=flag)


def test_jit_takes_the_interpreted_trajectory_bit_for_bit_and_survives_pickling(tmp_path, monkeypatch):
    monkeypatch.setenv("PGI_JIT_CACHE", str(tmp_path / "jit"))
    run = {**RIGID_BODY, "order": 8, "dt": 0.2, "x0": [0.6, 0.0, 0.8], "t_end": 5}
    plain, native = pgi.Scheme(**run), pgi.Scheme(**run, jit=True)
    assert native.jit and not plain.jit
    a, b = plain.integrate(), native.integrate()
    assert np.array_equal(a.x, b.x) and a.steps == b.steps  # the same doubles, not merely close
    assert any(p.suffix == ".so" for p in (tmp_path / "jit").iterdir())  # the native code was built
    assert pickle.loads(pickle.dumps(native)).jit
    with pytest.raises(ValueError, match="jit: must be True or False"):
        pgi.Scheme(**RIGID_BODY, jit="yes")
    monkeypatch.setenv("PGI_CXX", "/nonexistent/pgi-cc")
    monkeypatch.setenv("PGI_JIT_CACHE", str(tmp_path / "other"))
    with pytest.raises(pgi.NativeCodeError, match="/nonexistent/pgi-cc"):
        pgi.Scheme(**{**run, "order": 6}, jit=True).integrate()


@pytest.mark.parametrize("scene, says", [("jacobi_failure.toml", r"brackets: the Jacobi identity fails at \(x1, x2, x3\): jacobiator = "),
                                         ("false_casimir.toml", r"hamiltonian.casimirs\[1\]: 'x1\*x2' is not a Casimir")])
def test_every_exact_method_and_run_refuses_an_invalid_scheme_as_the_command_line_does(scene, says):
    path = BAD_SCENES / scene
    code, _, err = cli("integrate", path, "--x0", "0.6,0.8,0.3", "--t-end", 1, check=False)
    assert code == 2
    x = np.array([0.6, 0.8, 0.3])
    for s in (pgi.Scheme.from_toml(path), pickle.loads(pickle.dumps(pgi.Scheme.from_toml(path)))):
        for call in (s.require_valid, s.terms, lambda: s.modified_hamiltonian(2), lambda: s.step(x, 0.1),
                     lambda: s.integrate(x, dt=0.1, t_end=1), lambda: s.integrate_ensemble(np.array([x, x]), dt=0.1, t_end=1)):
            with pytest.raises(pgi.InputError, match=says) as e:
                call()
            assert str(e.value) in err  # the command line's message, word for word


def test_a_coordinate_named_as_a_momentum_is_refused_as_the_command_line_refuses_it():
    code, _, err = cli("check", BAD_SCENES / "coordinate_named_as_a_momentum.toml", check=False)
    with pytest.raises(pgi.InputError, match=r"coordinates: coordinate 'p_x' is the name of the momentum of coordinate 'x'"
                       ) as e:
        pgi.Scheme(coordinates=["x", "p_x"], brackets={"x,p_x": "1"}, hamiltonian="x^2/2 + p_x^2/2")
    assert code == 2 and str(e.value) in err


def test_a_bracket_failing_jacobi_from_values_is_refused_unless_trusted():
    broken = dict(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "1", "x2,x3": "-x2", "x3,x1": "x1"},
                  hamiltonian="x1^2/2 + x2^2/2 + x3^2/2", dt=0.1, x0=[0.6, 0.8, 0.3], t_end=1)
    s = pgi.Scheme(**broken)
    says = r"brackets: the Jacobi identity fails at \(x1, x2, x3\): jacobiator = \S"
    for call in (s.terms, s.modified_hamiltonian, lambda: s.step(s.x0), s.integrate,
                 lambda: s.integrate_ensemble(np.array([s.x0]))):
        with pytest.raises(pgi.InputError, match=says):
            call()
    trusted = pgi.Scheme(**broken, trust_jacobi=True)  # the caller vouches: the run goes ahead
    assert len(trusted.terms()) == 2 and trusted.step(trusted.x0).shape == (3,)
    # (without Jacobi the realisation is no groupoid's: at dt = 0.1 its truncation outgrows round-off at step 8, and
    # the run stops there, as any run whose step is not Poisson to round-off does)
    with pytest.raises(pgi.StepFailure, match="realisation truncated above its bound"):
        trusted.integrate()
    assert trusted.integrate(dt=0.05).steps == 20
    assert pgi.Scheme.from_toml(BAD_SCENES / "jacobi_failure.toml", trust_jacobi=True).terms()


def test_a_run_never_depends_on_the_runs_before_it_on_the_scheme():
    """A kept step is served only to the typical magnitudes it was sized for: a run at x after one at the scene's x0
    is the run a fresh scheme (or a pickled copy) makes at x, bit for bit, where the step sized at x0 stopped."""
    scene = SCENES / "plane_quadratic.toml"
    x = np.array([0.8, 0.3]) * 1.9
    fresh = pgi.Scheme.from_toml(scene).integrate(x, 0.05, 10)
    used = pgi.Scheme.from_toml(scene)
    used.integrate(used.x0, 0.05, 1)
    copy = pickle.loads(pickle.dumps(used))
    for r in (used.integrate(x, 0.05, 10), copy.integrate(x, 0.05, 10)):
        assert r.status == "ok" and np.array_equal(r.x, fresh.x)


def test_a_step_past_its_realisation_s_range_stops_instead_of_drifting():
    """Nambu's radial series at dt = 2 leaves 6.6e-13 per step: the step fails (the run kept its Casimir off by
    7.2e-13 and said ok while the bound was 1e-12); at dt = 1.5 it is within round-off and the Casimir stays there."""
    s = pgi.Scheme.from_toml(SCENES / "nambu.toml")
    with pytest.raises(pgi.StepFailure, match="realisation truncated above its bound") as failure:
        s.integrate(dt=2)
    assert failure.value.step == 1
    ok = s.integrate(dt=1.5)
    assert ok.status == "ok" and max(ok.casimir_error_max) < 4 * 1.1e-16 * np.sqrt(ok.steps)  # 4 u sqrt(N)
