// RunLoop: the one run loop (pgi integrate, section, Python, ensembles): what the observer sees, how the
// run ends (observer, terminal event, failed step, non-finite invariant) and the state it leaves.
#include "scheme/run_loop.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

using namespace pgi;

namespace {
Eigen::VectorXd vec(std::initializer_list<double> v) {
    Eigen::VectorXd x(Eigen::Index(v.size()));
    Eigen::Index i = 0;
    for (double a : v) x(i++) = a;
    return x;
}
}  // namespace

TEST_CASE("RunLoop: the observer sees every state once, in order, with the invariants there") {
    const Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = vec({0.6, 0.8, 0.3});
    NewtonStepper st = s.scheme->stepper(0.1, x0);
    RunLoop loop(*s.scheme);
    CHECK(loop.names() == std::vector<std::string>{"H", "C1"});
    Eigen::VectorXd x = x0;
    std::vector<std::size_t> steps;
    std::size_t finals = 0;
    double worst = 0;
    const RunEnd end = loop.run(st, x, 25, [&](const RunPoint& p) {
        steps.push_back(p.step);
        CHECK(p.t == double(p.step) * 0.1);
        // H at this state (three positive terms, summed in another order: within 4 u H of each other)
        const double H = 0.25 * p.x(0) * p.x(0) + 0.5 * p.x(1) * p.x(1) + 0.75 * p.x(2) * p.x(2);
        CHECK(std::abs(loop.values()[0] - H) <= 4 * 0x1p-53 * H);
        worst = std::max(worst, loop.error(0));
        finals += p.final;
        CHECK(p.final == (p.step == 25));
        return false;
    });
    REQUIRE(steps.size() == 26);
    for (std::size_t n = 0; n <= 25; ++n) CHECK(steps[n] == n);
    CHECK(finals == 1);
    CHECK(end.ok());
    CHECK(end.started);
    CHECK(!end.stopped);
    CHECK(end.steps == 25);
    CHECK(end.t == 25 * 0.1);
    CHECK(worst > 0);
    CHECK(loop.error_max()[0] == worst);
    // the observer ends the run: stopped, not failed, x the state it saw last
    x = x0;
    Eigen::VectorXd seen;
    const RunEnd stop = loop.run(st, x, 25, [&](const RunPoint& p) {
        seen = p.x;
        return p.step == 7;
    });
    CHECK(stop.ok());
    CHECK(stop.stopped);
    CHECK(!stop.terminal_event);
    CHECK(stop.steps == 7);
    CHECK(x == seen);
}

TEST_CASE("RunLoop: a terminal event's crossing is the final state, observed at its t") {
    const Scene s = test::bundled("harmonic_oscillator");
    const Eigen::VectorXd x0 = vec({1.0, 0.0});
    NewtonStepper st = s.scheme->stepper(0.1, x0);
    EventDetector detector(EventSet::build(s.phase_space(), {{"q", -1, true}}),
                           DenseOutput::build(s.pi, s.H, st.order()));
    RunLoop loop(*s.scheme);
    Eigen::VectorXd x = x0;
    std::vector<Crossing> crossings;
    double last_t = -1;
    Eigen::VectorXd last_x;
    bool last_final = false;
    const RunEnd end = loop.run(
        st, x, 100,
        [&](const RunPoint& p) {
            last_t = p.t;
            last_x = p.x;
            last_final = p.final;
            return false;
        },
        &detector,
        [&](const Crossing& c) {
            crossings.push_back(c);
            return false;
        });
    REQUIRE(crossings.size() == 1);
    CHECK(end.ok());
    CHECK(end.stopped);
    CHECK(end.terminal_event);
    CHECK(end.crossings == 1);
    CHECK(end.steps == 16);  // pi/2 lies in step 16 (t from 1.5 to 1.6)
    CHECK(end.t == crossings[0].t);
    CHECK(last_final);
    CHECK(last_t == crossings[0].t);
    CHECK(last_x == crossings[0].x);
    CHECK(x == crossings[0].x);
    // the scene's k = 2 is the midpoint rule, a rotation by 2 atan(h / 2) per step of size h: the crossing's state is
    // a partial step of it after 15 whole steps, so q = 0 at t = 1.5 + h with 15 * 2 atan(0.05) + 2 atan(h / 2) = pi/2
    // (the dense output's crossing, late by t dt^2/12 throughout, was 3e-5 later)
    const double h = 2 * std::tan((std::numbers::pi / 2 - 30 * std::atan(0.05)) / 2);
    CAPTURE(end.t - (1.5 + h));
    CHECK(std::abs(end.t - (1.5 + h)) < 1e-13);
}

TEST_CASE("RunLoop: a failed step or a non-finite invariant ends the run, x the last good state, with its message") {
    const Scene s = test::bundled("rigid_body");
    const Scheme k2(s.pi, s.H, s.casimirs, 2);
    const Eigen::VectorXd x0 = vec({0.4535961214255773, 0.0, 0.8912073600614354});
    NewtonStepper st = k2.stepper(5.0, x0);  // dt = 5 at k = 2: Newton fails at step 3 (pgi integrate says so too)
    RunLoop loop(k2);
    Eigen::VectorXd x = x0, last;
    const RunEnd end = loop.run(st, x, 100, [&](const RunPoint& p) {
        last = p.x;
        return false;
    });
    REQUIRE(!end.ok());
    CHECK(end.started);
    CHECK(end.steps == 2);
    CHECK(x == last);
    CHECK(loop.failure_message(st, end) == step_failure_message(st, end.steps + 1, end.status));
    // H = inf at the start: nothing is observed
    x = vec({1e200, 0, 0});
    std::size_t observed = 0;
    const RunEnd at_start = loop.run(st, x, 10, [&](const RunPoint&) {
        ++observed;
        return false;
    });
    CHECK(observed == 0);
    CHECK(at_start.status == StepStatus::non_finite);
    CHECK(!at_start.started);
    CHECK(at_start.non_finite == "H = inf");
    CHECK(loop.failure_message(st, at_start) == "the invariant H = inf at x0 is not finite: nothing to integrate");
}
