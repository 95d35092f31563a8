"""Events on Scheme.integrate: crossings against the exact flow (oscillator) and an independent reference
(rigid body, scipy's DOP853 and its own event location), directions, terminal events, bad events refused."""
import math

import numpy as np
import pytest

import pgi
from conftest import SCENES


def oscillator(k):
    return pgi.Scheme(coordinates=["q", "p"], brackets={"q,p": "1"}, hamiltonian="(q^2 + p^2)/2", order=k)


# The scheme on the oscillator is the time-dt flow of its modified Hamiltonian Htilde = w(dt) H, a rotation
# at frequency w(dt) = 1 - c dt^p + O(dt^(p+2)), p the method order (docs/math.md section 7; pgi's exact
# Htilde for k = 2, 4, 6 gives c = 1/12 (the midpoint rule: w = (2/dt) arctan(dt/2)), 1/120, 17/20160). So
# the j-th crossing of q = 0 (exactly at t_j = pi/2 + j pi for q = cos t) is where the rotated angle is t_j.
# The crossing's state is a partial step of size h after n whole steps (t = n dt + h), itself a rotation by
# h w(h), so n dt w(dt) + h w(h) = t_j: late by c (n dt^(p+1) + h^(p+1)), up to O(dt^2) relative (3% here).
@pytest.mark.parametrize("k, c", [(2, 1 / 12), (4, 1 / 120), (6, 17 / 20160)])
def test_oscillator_crossings_of_q_against_the_exact_flow(k, c):
    s = oscillator(k)
    p = s.method_order
    for dt in (0.2, 0.1):
        r = s.integrate([1.0, 0.0], dt=dt, t_end=20, every=1000, events=["q"])
        assert r.status == "ok" and r.event_index.tolist() == [0] * 6  # pi/2 + j pi < 20, j = 0..5
        exact = np.pi / 2 + np.pi * np.arange(6)
        late = r.event_t - exact
        n = np.floor(r.event_t / dt)
        expected = c * (n * dt ** (p + 1) + (r.event_t - n * dt) ** (p + 1))
        assert np.all(np.abs(late / expected - 1) < 0.03), (k, dt, late, expected)
        assert np.all(np.abs(r.event_x[:, 0]) <= 1e-15)  # on the section, to round-off
        # the state there is the exact flow's at t_c, off by the time error (speed 1): a rotation stays on the circle
        flow = np.stack([np.cos(r.event_t), -np.sin(r.event_t)], axis=1)
        assert np.all(np.linalg.norm(r.event_x - flow, axis=1) <= 1.03 * np.abs(late) + 1e-14)
        assert r.event_step.tolist() == np.ceil(r.event_t / dt).astype(int).tolist()


def test_directions_and_several_events():
    s = oscillator(4)
    r = s.integrate([1.0, 0.0], dt=0.05, t_end=10, every=1000,
                    events=[("q", -1), {"g": "p", "direction": 1}, ("q - 1/2", 0, False)])
    # q = cos t falls through 0 at pi/2, 5 pi/2; p = -sin t rises through 0 at pi, 3 pi; q = 1/2 at pi/3 + ...
    expect = sorted([(np.pi / 2 + 2 * np.pi * j, 0) for j in range(2)] + [(np.pi + 2 * np.pi * j, 1) for j in range(2)]
                    + [(a, 2) for a in (np.pi / 3, 5 * np.pi / 3, 7 * np.pi / 3)])
    assert r.event_index.tolist() == [i for _, i in expect]
    assert np.all(np.diff(r.event_t) > 0)
    assert np.allclose(r.event_t, [t for t, _ in expect], atol=1e-5)  # c t dt^4 <= 1e-7 at t = 10


def test_a_terminal_event_ends_the_run_at_its_crossing():
    s = oscillator(4)
    r = s.integrate([1.0, 0.0], dt=0.1, t_end=20, every=5, events=[("p", 1), ("q", -1, True)])
    assert r.status == "terminal_event"  # not a failure: nothing raised
    assert r.event_index.tolist() == [1]  # p rises only at pi, after q's fall at pi/2
    assert r.steps == 16  # pi/2 lies in step 16 (t from 1.5 to 1.6)
    assert r.t[-1] == r.event_t[0] and r.x[-1].tolist() == r.event_x[0].tolist()
    assert r.t.tolist()[:-1] == [0.0, 0.5, 1.0, 1.5]  # every 5th step up to the crossing, not step 16 itself
    assert abs(r.event_t[0] - np.pi / 2) < 1e-4 and r.energy_error[-1] < 1e-6
    assert abs(r.x[-1, 0]) <= 1e-15


def rigid_body_field(t, x):
    # xdot = pi grad H for {x1, x2} = -x3 (cyclic), H = x1^2/4 + x2^2/2 + 3 x3^2/4, written out by hand
    return [x[1] * x[2] / 2, -x[0] * x[2], x[0] * x[1] / 2]


def test_rigid_body_section_against_an_independent_reference():
    # the reference: scipy's DOP853 at rtol 1e-13 with its own event location (error ~1e-11 at T = 30).
    # Order 4: the crossing times err by O(t dt^4); halving dt must divide the error by 2^4 = 16 (measured
    # between 0.8 and 1.25 times that), and at dt = 0.05 they are below 1e-6 (the C++ section test measures
    # 1.0e-7; the method's constant: about 5e-4 t dt^4).
    integrate = pytest.importorskip("scipy.integrate")
    s = pgi.Scheme.from_toml(SCENES / "rigid_body.toml")
    x0 = np.array(s.x0)
    rising = lambda t, x: x[1]  # noqa: E731
    rising.direction = 1
    ref = integrate.solve_ivp(rigid_body_field, (0, 30), x0, method="DOP853", rtol=1e-13, atol=1e-15, events=rising)
    t_ref = ref.t_events[0]
    assert len(t_ref) >= 3
    errors = []
    for dt in (0.1, 0.05):
        r = s.integrate(x0, dt=dt, t_end=30, every=1000, events=[("x2", 1)])
        assert len(r.event_t) == len(t_ref)
        assert np.all(np.abs(r.event_x[:, 1]) <= 1e-15)
        errors.append(np.max(np.abs(r.event_t - t_ref)))
        # the section point is fixed by H and the Casimir, which the method keeps (H to its bounded error, C to
        # round-off): it is far closer to the reference's than the time error moves the state along the orbit
        state_error = np.max(np.abs(r.event_x - ref.y_events[0]))
        assert state_error < 0.1 * errors[-1], (state_error, errors[-1])
    assert 0.8 * 16 <= errors[0] / errors[1] <= 1.25 * 16, errors
    assert errors[1] < 1e-6, errors


def test_bad_events_raise_value_errors_naming_them():
    s = oscillator(2)
    run = lambda events: s.integrate([1.0, 0.0], dt=0.1, t_end=1, events=events)  # noqa: E731
    with pytest.raises(ValueError, match=r"^events\[1\]: malformed polynomial 'q \+ w': unknown variable 'w' at position 5"):
        run(["q", "q + w"])
    with pytest.raises(ValueError, match=r"events\[0\]: malformed polynomial 'q\^': .*position"):
        run(["q^"])
    with pytest.raises(ValueError, match=r"events\[0\]: '3/2' is constant, it never crosses zero"):
        run(["3/2"])
    with pytest.raises(ValueError, match=r"events\[0\]: direction must be -1, 0 or 1, got 2"):
        run([("q", 2)])
    with pytest.raises(ValueError, match=r"events\[0\]: terminal must be True or False"):
        run([("q", 1, "yes")])
    with pytest.raises(ValueError, match=r"events\[0\]: a dict needs the key 'g'.*\['where'\]"):
        run([{"g": "q", "where": 1}])
    with pytest.raises(ValueError, match=r"events: must be a list"):
        run("q")
    with pytest.raises(ValueError, match="event_samples"):
        s.integrate([1.0, 0.0], dt=0.1, t_end=1, events=["q"], event_samples=0)
    assert isinstance(pytest.raises(ValueError, run, ["w"]).value, pgi.InputError)


def test_interior_samples_find_two_crossings_inside_one_step():
    # q = cos(t - 1/5) crosses 99/100 at 0.2 -+ acos(0.99), both inside the one step of dt = 1/2
    s = oscillator(4)
    x0 = [math.cos(0.2), math.sin(0.2)]
    assert len(s.integrate(x0, dt=0.5, t_end=0.5, events=["q - 99/100"]).event_t) == 0
    r = s.integrate(x0, dt=0.5, t_end=0.5, events=["q - 99/100"], event_samples=4)
    assert np.allclose(r.event_t, [0.2 - math.acos(0.99), 0.2 + math.acos(0.99)], atol=1e-3)
