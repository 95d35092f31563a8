"""Every run surface of Python under the library's one validation of a run (plan_run): budgets of steps,
recorded output and event samples refused before any work as `pgi integrate` refuses them; an ensemble member
ends with its single run's status; the interpreter survives memory exhaustion; Ctrl-C stops a long run."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import pgi
import pgi.dask
from conftest import SCENES, cli
from test_scheme import RIGID_BODY

X0 = [0.6, 0.8, 0.3]


def python(script, *args, **kwargs):
    """A child /usr/bin/python3 (this interpreter) running script with pgi importable as here."""
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(script), *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=dict(os.environ), **kwargs)


@pytest.mark.parametrize("dt, t_end", [(1e-300, 1e300), (1e-20, 1e20), (1e-9, 1.0)])
def test_a_run_above_the_step_budget_is_refused_before_any_work(dt, t_end):
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="above the step budget of 100000000"):
        s.integrate(X0, dt=dt, t_end=t_end)
    with pytest.raises(pgi.ResourceLimitError, match="above the step budget of 100000000"):
        s.integrate_ensemble(np.array([X0, X0]), dt=dt, t_end=t_end)


def test_the_step_budget_is_max_steps_as_the_command_lines_max_steps():
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="needs 101 steps, above the step budget of 100 "):
        s.integrate(X0, dt=0.1, t_end=10.1, max_steps=100)
    assert s.integrate(X0, dt=0.1, t_end=10, max_steps=100).steps == 100
    with pytest.raises(pgi.ResourceLimitError, match="above the step budget of 100 "):
        s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=10.1, max_steps=100)
    assert s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=10, max_steps=100).steps.tolist() == [100]
    code, _, err = cli("integrate", SCENES / "rigid_body.toml", "--t-end", "10.1", "--dt", "0.1", "--max-steps", 100,
                       check=False)
    assert code == 4  # the command line's exit for the same run
    for bad in (0, -1, 1.5, True, "100"):
        with pytest.raises(pgi.InputError, match="max_steps"):
            s.integrate(X0, dt=0.1, t_end=1, max_steps=bad)


def test_recorded_output_above_its_budget_is_refused_before_any_work():
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="above the output budget of 1024 MB"):
        s.integrate(X0, dt=1e-6, t_end=100, every=1)  # 1e8 rows: 4.8 GB
    with pytest.raises(pgi.ResourceLimitError, match="output budget of 0.01 MB"):
        s.integrate(X0, dt=0.1, t_end=100, max_output_mb=0.01)
    assert len(s.integrate(X0, dt=0.1, t_end=100, every=100, max_output_mb=0.01).t) == 11
    with pytest.raises(pgi.ResourceLimitError, match="1000 trajectories"):
        s.integrate_ensemble(np.tile(X0, (1000, 1)), dt=0.1, t_end=1, max_output_mb=0.01)
    for bad in (0, -1.0, float("nan"), True, "1"):
        with pytest.raises(pgi.InputError, match="max_output_mb"):
            s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=1, max_output_mb=bad)


def test_event_samples_above_the_limit_are_refused_before_any_work():
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="event_samples = 1000000000 is above the limit of 10000"):
        s.integrate(X0, dt=0.1, t_end=1, events=["x1"], event_samples=10**9)
    with pytest.raises(pgi.InputError, match="event_samples"):
        s.integrate(X0, dt=0.1, t_end=1, events=["x1"], event_samples=0)



def test_more_events_than_a_run_may_watch_are_refused_before_any_work():
    """Each crossing is located with every event's value: 30000 events crossing together took 17 s a step."""
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="257 events are above the limit of 256 per run"):
        s.integrate(X0, dt=0.1, t_end=1, events=["x1"] * 257)
    with pytest.raises(pgi.ResourceLimitError, match="257 events"):
        s.integrate_ensemble(np.array([X0]), dt=0.1, t_end=1, events=["x1"] * 257)
    assert s.integrate(X0, dt=0.1, t_end=1, events=["x1"] * 256).status == "ok"


class NoCluster:
    """A Dask client that must not be used: every check comes before submitting."""

    def scheduler_info(self):
        return {"workers": {"a": {}}}

    def submit(self, *args, **kwargs):
        raise AssertionError("submitted a task of a run that should have been refused")


def test_dask_runs_are_refused_above_their_budgets_before_submitting():
    s = pgi.Scheme(**RIGID_BODY)
    with pytest.raises(pgi.ResourceLimitError, match="step budget"):
        pgi.dask.integrate_ensemble(NoCluster(), s, np.array([X0]), dt=1e-20, t_end=1e20)
    with pytest.raises(pgi.ResourceLimitError, match="step budget of 10 "):
        pgi.dask.integrate_ensemble(NoCluster(), s, np.array([X0]), dt=0.1, t_end=2, max_steps=10)
    # the whole ensemble's results against the budget, not one chunk's
    with pytest.raises(pgi.ResourceLimitError, match="1000 trajectories"):
        pgi.dask.integrate_ensemble(NoCluster(), s, np.tile(X0, (1000, 1)), dt=0.1, t_end=1, chunks=10, max_output_mb=0.01)
    with pytest.raises(pgi.ResourceLimitError, match="step budget"):
        pgi.dask.sweep(NoCluster(), [dict(scheme=s, X0=np.array([X0]), dt=0.1, t_end=1),
                                     dict(scheme=s, X0=np.array([X0]), dt=1e-300, t_end=1e300)])


def cyclic_lotka_volterra(**kwargs):
    return pgi.Scheme(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "x1*x2", "x2,x3": "x2*x3", "x3,x1": "x3*x1"},
                      hamiltonian="x1 + x2 + x3", casimirs=["x1*x2*x3"], order=4, **kwargs)


def test_an_ensemble_member_ends_with_the_status_of_its_single_run():
    s = cyclic_lotka_volterra(realisation="radial")
    x0 = [1.0, 2.0, 0.5]  # the scene's (tools/scenes/lotka_volterra.toml)
    with pytest.raises(pgi.StepFailure) as e:
        s.integrate(x0, dt=2.0, t_end=10)
    single = e.value.result
    assert e.value.step == 1 and single.status != "ok"
    r = s.integrate_ensemble(np.array([x0, x0]), dt=2.0, t_end=10, x_typical=np.array(x0))
    assert r.status.tolist() == [single.status] * 2
    assert r.steps.tolist() == [0, 0] and r.failed_step.tolist() == [1, 1]
    assert not r.ok.any()


def test_an_ensemble_too_large_for_the_address_space_raises_instead_of_crashing():
    # X0 of 200e6 rows as a broadcast view (no memory); its contiguous copy would take 4.8 GB
    p = python(f"""
        import resource
        import numpy as np
        import pgi
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
        s = pgi.Scheme(**{RIGID_BODY!r})
        X0 = np.broadcast_to(np.array({X0!r}), (200_000_000, 3))
        # the budget refuses it; above a raised budget, the copy of X0, then (30e6 rows: 0.7 GB copied) the results
        for rows, limits in ((X0, {{}}), (X0, {{"max_output_mb": 1e9}}), (X0[:30_000_000], {{"max_output_mb": 1e9}})):
            try:
                s.integrate_ensemble(rows, dt=0.1, t_end=0.1, **limits)
                print("ran")
            except (pgi.ResourceLimitError, MemoryError) as e:
                print(type(e).__name__ + ":", e)
        """)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 0, (p.returncode, err)  # not -11 (SIGSEGV)
    budget, copy, results = out.splitlines()
    assert budget.startswith("ResourceLimitError:") and "output budget of 1024 MB" in budget
    assert copy.startswith("MemoryError: X0: out of memory") and "(200000000, 3)" in copy
    assert results.startswith("MemoryError: out of memory (std::bad_alloc): what this call keeps did not fit")


LONG_RUNS = {
    # 1e8 steps of the rigid body: tens of seconds
    "integrate": "s.integrate([0.6, 0.8, 0.3], dt=1e-4, t_end=1e4, every=10**6)",
    "integrate_ensemble": "s.integrate_ensemble(np.tile([0.6, 0.8, 0.3], (64, 1)), dt=1e-3, t_end=1e4)",
}


@pytest.mark.parametrize("run", sorted(LONG_RUNS))
def test_ctrl_c_stops_a_long_run_with_keyboard_interrupt(run):
    p = python(f"""
        import numpy as np
        import pgi
        s = pgi.Scheme(**{RIGID_BODY!r})
        print("started", flush=True)
        try:
            {LONG_RUNS[run]}
            print("finished", flush=True)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
        """)
    try:
        assert p.stdout.readline() == "started\n"
        time.sleep(1.5)
        assert p.poll() is None  # still running
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=5)  # a generous bound: stopped within a step, not at the run's end
    finally:
        p.kill()
    assert out == "interrupted\n", (out, err)
    assert p.returncode == 0
