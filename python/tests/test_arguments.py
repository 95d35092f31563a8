"""Python's arguments checked as the command line checks its options: a wrong type or a value out of range is
a pgi.InputError (a ValueError) naming the argument, before any work; never a silent conversion (a complex
number's imaginary part, a bool taken as 1, one string split into characters) nor pybind11's raw TypeError."""
import inspect
import pydoc
import warnings

import numpy as np
import pytest

import pgi
from conftest import SCENES
from test_scheme import RIGID_BODY

X0 = [0.6, 0.8, 0.3]


@pytest.fixture
def s():
    return pgi.Scheme(**RIGID_BODY)


def refused(match, call):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning would mean a value was converted
        with pytest.raises(pgi.InputError, match=match) as e:
            call()
    assert "incompatible function arguments" not in str(e.value)
    return e.value


def test_complex_states_are_refused_naming_the_argument(s):
    z = np.array([0.6 + 1e-3j, 0.8, 0.3])
    refused("x0: complex values", lambda: s.integrate(z, dt=0.1, t_end=1))
    refused("x: complex values", lambda: s.step(z, 0.1))
    refused("x_typical: complex values", lambda: s.integrate(X0, dt=0.1, t_end=1, x_typical=z))
    refused("X0: must have dtype float64, got complex128", lambda: s.integrate_ensemble(np.array([z, z]), dt=0.1, t_end=1))
    refused("X0: complex values", lambda: s.integrate_ensemble([[1j, 0, 0]], dt=0.1, t_end=1))
    refused("x0: complex values", lambda: pgi.Scheme(**RIGID_BODY, x0=z))
    refused("x0: complex values", lambda: s.integrate([0.6 + 0j, 0.8, 0.3], dt=0.1, t_end=1))


def test_a_bool_is_not_a_number_here(s):
    refused("dt: must be a number, got True", lambda: s.integrate(X0, dt=True, t_end=1))
    refused("t_end: must be a number, got True", lambda: s.integrate(X0, dt=0.1, t_end=True))
    refused("dt: must be a number", lambda: s.step(X0, dt=np.bool_(True)))
    refused("order: True is not a whole number from 1 to 64", lambda: pgi.Scheme(**{**RIGID_BODY, "order": True}))
    refused("every: True is not a whole number", lambda: s.integrate(X0, dt=0.1, t_end=1, every=True))
    refused("event_samples: True", lambda: s.integrate(X0, dt=0.1, t_end=1, events=["x1"], event_samples=True))
    refused("upto: True", lambda: s.modified_hamiltonian(True))
    refused("x0: must be a vector of 3 numbers, got dtype bool", lambda: s.integrate([True, False, True], dt=0.1, t_end=1))


def test_wrong_types_and_ranges_name_the_argument(s):
    refused("every: -1 is not a whole number from 1 to", lambda: s.integrate(X0, dt=0.1, t_end=1, every=-1))
    refused("every: 0 is not a whole number", lambda: s.integrate(X0, dt=0.1, t_end=1, every=0))
    refused("every: 2.0 is not a whole number", lambda: s.integrate(X0, dt=0.1, t_end=1, every=2.0))
    refused(r"x0: must have 3 values \(one per coordinate, a vector\), got an array of shape \(1, 3\)",
            lambda: s.integrate([X0], dt=0.1, t_end=1))
    refused(r"x: must have 3 values .*shape \(3, 3\)", lambda: s.step(np.eye(3), 0.1))
    refused("dt: must be a number, got '0.1'", lambda: s.integrate(X0, dt="0.1", t_end=1))
    refused("dt: must be a number, got '0.1'", lambda: s.step(X0, "0.1"))
    refused("dt: must be a number", lambda: s.integrate_ensemble(np.array([X0]), dt="0.1", t_end=1))
    refused("t_end: must be a number, got '1'", lambda: s.integrate(X0, dt=0.1, t_end="1"))
    refused("dt: must be positive and finite", lambda: s.integrate(X0, dt=float("inf"), t_end=1))
    refused("t_end: must be finite and not negative", lambda: s.integrate(X0, dt=0.1, t_end=-1))
    refused("x0: must be a vector of 3 numbers, got a string", lambda: s.integrate("0.6 0.8 0.3", dt=0.1, t_end=1))
    refused("x0: must be finite", lambda: s.integrate([np.nan, 0, 0], dt=0.1, t_end=1))
    refused("x_typical: must have 3 values", lambda: s.integrate(X0, dt=0.1, t_end=1, x_typical=[1.0]))
    refused("threads: 1.5 is not a whole number", lambda: s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=1, threads=1.5))
    refused("chunk: -2 is not a whole number", lambda: s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=1, chunk=-2))
    refused("latex: must be True or False", lambda: s.terms(latex=1))
    refused("max_terms: 0 is not a whole number", lambda: pgi.Scheme(**RIGID_BODY, max_terms=0))
    refused("realisation: must be a string", lambda: pgi.Scheme(**RIGID_BODY, realisation=None))
    refused("brackets: must be a dict", lambda: pgi.Scheme(**{**RIGID_BODY, "brackets": [("x1,x2", "-x3")]}))
    # numbers of other kinds are numbers
    assert s.integrate(np.array(X0, dtype=np.float32), dt=np.float64(0.1), t_end=np.int64(1), every=np.int32(5)).steps == 10


def test_the_exact_methods_take_the_command_lines_ranges(s):
    # refused at once: modified_hamiltonian(10**6) ran until the exact phase's memory budget (2.3 GB)
    refused("upto: 1000000 is not a whole number from 0 to 64", lambda: s.modified_hamiltonian(10**6))
    refused("upto: -1 is not a whole number from 0 to 64", lambda: s.modified_hamiltonian(-1))
    refused("upto: 2.0", lambda: s.modified_hamiltonian(2.0))
    refused("degree: 101 is not a whole number from 0 to 100", lambda: s.realisation_terms(101))
    refused("degree: -1", lambda: s.realisation_terms(-1))
    refused("order: 65 is not a whole number from 1 to 64", lambda: pgi.Scheme(**{**RIGID_BODY, "order": 65}))
    refused("order: 4.0", lambda: pgi.Scheme(**{**RIGID_BODY, "order": 4.0}))
    assert len(s.modified_hamiltonian(0)) == 1 and s.realisation_terms(2)["degree"] >= 2


def test_one_string_where_a_list_is_expected_is_refused_with_a_hint():
    e = refused(r"casimirs: must be a list of polynomial strings, got one string 'x1\^2 \+ x2\^2 \+ x3\^2'",
                lambda: pgi.Scheme(**{**RIGID_BODY, "casimirs": "x1^2 + x2^2 + x3^2"}))
    assert "pass a list, like ['x1^2 + x2^2 + x3^2']" in str(e)
    refused("coordinates: must be a list of coordinate names, got one string",
            lambda: pgi.Scheme(**{**RIGID_BODY, "coordinates": "x1"}))
    refused(r"casimirs\[0\]: must be a string, got 3", lambda: pgi.Scheme(**{**RIGID_BODY, "casimirs": [3]}))


def test_a_python_power_gets_the_hint_to_write_a_caret():
    for where, values in [("hamiltonian", {"hamiltonian": "x1**2"}),
                          (r"casimirs\[0\]", {"casimirs": ["x1**2 + x2**2 + x3**2"]}),
                          ('brackets."x1,x2"', {"brackets": {**RIGID_BODY["brackets"], "x1,x2": "-x3**1"}})]:
        e = refused(f"{where}: '\\*\\*' is not a power in pgi: write x\\^2", lambda: pgi.Scheme(**{**RIGID_BODY, **values}))
        assert "^" in str(e)
    s = pgi.Scheme(**RIGID_BODY)
    refused(r"events\[0\]: '\*\*'", lambda: s.integrate(X0, dt=0.1, t_end=1, events=["x1**2 - 0.1"]))


def test_decimal_coefficients_are_read_as_exact_rationals():
    decimals = pgi.Scheme(**{**RIGID_BODY, "hamiltonian": "0.25*x1^2 + 0.5*x2^2 + 7.5e-1*x3^2",
                             "casimirs": ["1.0*x1^2 + (0.1 + 0.9)*x2^2 + 1e0*x3^2"]})
    fractions = pgi.Scheme(**RIGID_BODY)
    assert decimals.hamiltonian == fractions.hamiltonian and decimals.casimirs == fractions.casimirs
    assert decimals.terms() == fractions.terms()
    assert pgi.Scheme(**{**RIGID_BODY, "hamiltonian": "0.05*x1^2"}).hamiltonian == "1/20*x1^2"
    refused(r"hamiltonian.H: malformed polynomial .*'1e999999' is not a number "
            r"\(exponent out of range: at most 400 in absolute value\) at position 12",
            lambda: pgi.Scheme(**{**RIGID_BODY, "hamiltonian": "0.5*x1^2 + 1e999999*x2"}))


def test_the_scheme_explains_itself_with_real_methods_and_properties():
    s = pgi.Scheme(**RIGID_BODY)
    names = set(dir(s))
    for name in ("check", "require_valid", "terms", "modified_hamiltonian", "realisation_terms", "step", "integrate",
                 "integrate_ensemble", "typical_state", "coordinates", "order", "method_order", "realisation",
                 "structure_class", "hamiltonian", "casimirs", "dt", "x0", "t_end", "name", "jacobi_trusted", "jit"):
        assert name in names, name
        assert getattr(pgi.Scheme, name).__doc__, name
    text = pydoc.render_doc(pgi.Scheme, renderer=pydoc.plaintext)
    for method in ("check", "terms", "modified_hamiltonian", "integrate", "integrate_ensemble"):
        assert f"{method}(self" in text, method
    assert "max_output_mb" in inspect.signature(pgi.Scheme.integrate).parameters
    assert "max_steps" in inspect.signature(pgi.Scheme.integrate_ensemble).parameters
    assert list(inspect.signature(pgi.Scheme.from_toml).parameters) == ["path", "trust_jacobi", "jit", "max_seconds",
                                                                        "max_memory_mb", "max_terms"]
    assert s.order == 4 and s.method_order == 4 and s.coordinates == ["x1", "x2", "x3"]


def test_a_scene_path_that_is_no_regular_file_is_refused_naming_it_without_waiting(tmp_path):
    import os
    import signal
    fifo, directory = tmp_path / "scene.toml", tmp_path / "dir.toml"
    os.mkfifo(fifo)
    directory.mkdir()
    signal.alarm(20)  # a FIFO opened for reading waits for a writer: a hang fails here instead
    try:
        for path, why in [(fifo, "not a regular file"), (directory, "is a directory"), (tmp_path / "none.toml", "")]:
            with pytest.raises(pgi.SceneError, match=str(path.name)) as e:
                pgi.Scheme.from_toml(path)
            assert why in str(e.value)
    finally:
        signal.alarm(0)


def test_from_toml_reads_no_more_than_a_scene_may_hold(tmp_path):
    """A scene file above pgi's 8 MiB limit is refused as the command line refuses it, by its size, before it is read
    (a 300 MB sparse file once took 600 MB of memory before its syntax error)."""
    import resource
    big = tmp_path / "big.toml"
    with open(big, "wb") as f:
        f.write((SCENES / "rigid_body.toml").read_bytes())
        f.truncate(300 << 20)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(pgi.SceneError, match=f"the file has {300 << 20} bytes, above the limit of {8 << 20}"):
        pgi.Scheme.from_toml(big)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100 << 10  # KiB: well under 300 MB


def test_from_toml_refuses_a_path_with_a_nul_byte_as_a_scene_error():
    with pytest.raises(pgi.SceneError, match="NUL byte"):
        pgi.Scheme.from_toml("a\0b.toml")
