"""The exact phase's budget from Python, as the command line's (--max-seconds, --max-memory-mb): a Scheme stops
its algebra with ResourceLimitError naming the limit, 60 seconds by default as pgi's; a pickled Scheme keeps it."""
import pickle
import time

import pytest

import pgi
from conftest import SCENES
from test_scheme import RIGID_BODY

HEAVY = dict(RIGID_BODY, order=12)


def refused_by_budget(keyword, make, upto=6):
    """The refusal of make()'s exact work: from the parse of H on, whichever operation sees the budget spent."""
    with pytest.raises(pgi.ResourceLimitError, match=keyword) as e:
        make().modified_hamiltonian(upto)
    return str(e.value)


def test_a_time_budget_stops_the_exact_phase_naming_it():
    text = refused_by_budget("max_seconds", lambda: pgi.Scheme(**HEAVY, max_seconds=1e-9))
    assert "above the time budget of 1e-09 s (raise it with --max-seconds or max_seconds)" in text


def test_a_memory_budget_stops_the_exact_phase_naming_it():
    text = refused_by_budget("max_memory_mb", lambda: pgi.Scheme(**HEAVY, max_memory_mb=1))
    assert "above the memory budget of 1 MB" in text


def test_the_default_budget_is_the_command_lines_and_lets_ordinary_work_through():
    s = pgi.Scheme(**HEAVY)
    assert s.description[1]["max_seconds"] == 60
    assert s.description[1]["max_memory_mb"] is None
    assert len(s.modified_hamiltonian(6)) > 0
    assert len(pgi.Scheme(**HEAVY, max_seconds=None).modified_hamiltonian(6)) > 0


def test_each_call_has_the_whole_time_budget_and_the_time_between_calls_never_counts():
    # the budget counts gaps under a second between operations as busy: 0.6 s of the caller's own work before
    # the second call, against a budget of 0.5 s, must not be charged to it
    s = pgi.Scheme(**HEAVY, max_seconds=0.5)
    s.modified_hamiltonian(2)
    time.sleep(0.6)
    assert len(s.modified_hamiltonian(6)) == 7


def test_a_scene_file_takes_the_same_budgets():
    path = SCENES / "rigid_body.toml"
    refused_by_budget("max_seconds", lambda: pgi.Scheme.from_toml(path, max_seconds=1e-9), upto=12)
    assert len(pgi.Scheme.from_toml(path).modified_hamiltonian(2)) > 0


def test_a_pickled_scheme_keeps_its_budget():
    # pickled with a roomy budget, then the description's budget made tiny: the copy must read it
    for s in (pgi.Scheme(**HEAVY, max_seconds=1e3), pgi.Scheme.from_toml(SCENES / "rigid_body.toml", max_seconds=1e3)):
        again = pickle.loads(pickle.dumps(s))
        assert again.description == s.description
        kind, *rest = s.description
        if kind == "values":
            tiny = ("values", dict(rest[0], max_seconds=1e-9))
        else:
            tiny = ("toml", *rest[:4], 1e-9, *rest[5:])
        refused_by_budget("max_seconds", lambda: pgi._rebuild(tiny), upto=12)


@pytest.mark.parametrize("value", [0, -1, float("nan"), float("inf"), 2e9, "60", True, 1j])
def test_a_bad_time_budget_is_refused_naming_it(value):
    with pytest.raises(pgi.InputError, match="max_seconds"):
        pgi.Scheme(**RIGID_BODY, max_seconds=value)
    with pytest.raises(pgi.InputError, match="max_seconds"):
        pgi.Scheme.from_toml(SCENES / "rigid_body.toml", max_seconds=value)


@pytest.mark.parametrize("value", [0, -1, 1.5, 2 ** 41, "8", True])
def test_a_bad_memory_budget_is_refused_naming_it(value):
    with pytest.raises(pgi.InputError, match="max_memory_mb"):
        pgi.Scheme(**RIGID_BODY, max_memory_mb=value)
    with pytest.raises(pgi.InputError, match="max_memory_mb"):
        pgi.Scheme.from_toml(SCENES / "rigid_body.toml", max_memory_mb=value)


def test_a_tampered_description_is_checked_as_the_constructors_check_it():
    kind, text, file, *rest = pgi.Scheme.from_toml(SCENES / "rigid_body.toml").description
    for position, name, value in [(2, "max_seconds", float("nan")), (2, "max_seconds", -1.0),
                                  (3, "max_memory_mb", True), (4, "max_terms", 0), (0, "trust_jacobi", "yes")]:
        tampered = list(rest)
        tampered[position] = value
        with pytest.raises(pgi.InputError, match=name):
            pgi._rebuild((kind, text, file, *tampered))


def test_a_scene_file_takes_the_terms_bound_its_refusal_names():
    with pytest.raises(pgi.ResourceLimitError, match="max_terms"):
        pgi.Scheme.from_toml(SCENES / "rigid_body.toml", max_terms=5).modified_hamiltonian(8)
