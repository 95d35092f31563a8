// Events: crossings located on the dense output, against the exact flow (oscillator) and a fine
// reference (rigid body); directions, terminal events, interior samples and refused polynomials.
#include "poisson/events.hpp"
#include "scheme/run_loop.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

using namespace pgi;

namespace {

Eigen::VectorXd vec(const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

struct Run {
    std::vector<Crossing> crossings;
    RunEnd summary;
    Eigen::VectorXd x;
};

Run run(const Scene& s, std::size_t k, double dt, Eigen::VectorXd x0, double T, std::vector<EventSpec> events,
        std::size_t samples = 1) {
    StepOptions opt;
    opt.k = k;
    opt.dt = dt;
    NewtonStepper st = NewtonStepper::build(s.pi, s.H, opt, x0);
    EventDetector detector(EventSet::build(s.phase_space(), std::move(events)),
                           DenseOutput::build(s.pi, s.H, st.order()), samples);
    Run r;
    r.x = std::move(x0);
    RunLoop loop(*s.scheme);  // the run of every surface, watching s's invariants
    r.summary = loop.run(
        st, r.x, std::size_t(std::llround(T / dt)), [](const RunPoint&) { return false; }, &detector,
        [&](const Crossing& c) {
            r.crossings.push_back(c);
            return false;
        });
    REQUIRE(r.summary.status == StepStatus::ok);
    return r;
}

// Classical RK4 with many small steps on the compiled field: the rigid body's reference flow.
Eigen::VectorXd flow(const CompiledMap& f, Eigen::VectorXd x, double t, double h_max) {
    auto F = [&](const Eigen::VectorXd& y) {
        Eigen::VectorXd r(y.size());
        f.eval(y.data(), r.data());
        return r;
    };
    const auto N = std::size_t(std::ceil(t / h_max));
    const double h = t / double(N);
    for (std::size_t n = 0; n < N; ++n) {
        Eigen::VectorXd k1 = F(x), k2 = F(x + 0.5 * h * k1), k3 = F(x + 0.5 * h * k2), k4 = F(x + h * k3);
        x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return x;
}

}  // namespace

TEST_CASE("events: the oscillator's crossings of q = 0 against its exact flow, with their order") {
    // q = cos t, p = -sin t: q falls through 0 at pi/2 + 2 pi j, rises at 3 pi/2 + 2 pi j. The scheme
    // is a rotation at a frequency off by O(dt^p), so crossing times drift by O(t dt^p): the error
    // must fall by 2^p per halving of dt (measured between 0.8 and 1.25 times it).
    Scene s = test::bundled("harmonic_oscillator");
    const double pi = std::numbers::pi, T = 20;
    for (std::size_t k : {2, 4, 6}) {
        const double p = double(2 * ((k + 1) / 2));
        double previous_error = 0, previous_state_error = 0;
        for (double dt : {0.2, 0.1, 0.05}) {
            const Run r = run(s, k, dt, vec({1.0, 0.0}), T, {{"q", 0, false}});
            REQUIRE(r.crossings.size() == 6);  // pi/2 + pi j < 20 for j = 0..5
            double error = 0, state_error = 0;
            for (std::size_t j = 0; j < r.crossings.size(); ++j) {
                const Crossing& c = r.crossings[j];
                CHECK(c.event == 0);
                CHECK(std::abs(c.x(0)) <= 1e-15);                   // on the section, to round-off
                CHECK((c.x(1) > 0) == (j % 2 == 1));                // falling (p < 0) first, then rising
                CHECK(c.step == std::size_t(std::ceil(c.t / dt)));  // found in the step that holds it
                error = std::max(error, std::abs(c.t - (pi / 2 + pi * double(j))));
                state_error = std::max(state_error, std::hypot(c.x(0) - std::cos(c.t), c.x(1) + std::sin(c.t)));
            }
            INFO("k = " << k << ", dt = " << dt << ": crossing time error " << error << " (previous " << previous_error
                        << "), state error " << state_error << " (previous " << previous_state_error << ")");
            if (previous_error > 0 && error > 1e-12) {
                CHECK(previous_error / error >= 0.8 * std::pow(2.0, p));
                CHECK(previous_error / error <= 1.25 * std::pow(2.0, p));
            }
            // the state at t_c against the exact flow at t_c: the phase drift moves it by the time error
            // times the speed 1, and the dense output adds its local error O(dt^(p+1)), ~ 1% of that here
            CHECK(state_error <= 1.01 * error + 1e-14);
            previous_error = error;
            previous_state_error = state_error;
        }
    }
}

TEST_CASE("events: directions select rising or falling crossings") {
    Scene s = test::bundled("harmonic_oscillator");
    const double pi = std::numbers::pi;
    const Run up = run(s, 4, 0.05, vec({1.0, 0.0}), 20, {{"q", +1, false}});
    const Run down = run(s, 4, 0.05, vec({1.0, 0.0}), 20, {{"q", -1, false}});
    REQUIRE(up.crossings.size() == 3);
    REQUIRE(down.crossings.size() == 3);
    for (std::size_t j = 0; j < 3; ++j) {
        CHECK(std::abs(up.crossings[j].t - (3 * pi / 2 + 2 * pi * double(j))) < 1e-5);
        CHECK(std::abs(down.crossings[j].t - (pi / 2 + 2 * pi * double(j))) < 1e-5);
    }
}

TEST_CASE("events: a terminal event stops the run at its first crossing, with the crossing's state") {
    Scene s = test::bundled("harmonic_oscillator");
    const Run r = run(s, 4, 0.1, vec({1.0, 0.0}), 20, {{"p", +1, false}, {"q", -1, true}});
    REQUIRE(r.crossings.size() == 1);  // p rises only at pi, after q's fall at pi/2
    CHECK(r.summary.stopped);
    CHECK(r.summary.crossings == 1);
    CHECK(r.summary.steps == 16);  // pi/2 lies in step 16 (t from 1.5 to 1.6)
    CHECK(r.summary.t == r.crossings[0].t);
    CHECK(std::abs(r.summary.t - std::numbers::pi / 2) < 1e-4);
    CHECK(r.x == r.crossings[0].x);
}

TEST_CASE("events: interior samples find two crossings inside one step, which the end points miss") {
    // q = cos(t - 1/5) crosses 99/100 at t = 0.2 -+ acos(0.99) = 0.0585 (up) and 0.3415 (down), both
    // inside the first step of dt = 1/2; q at both ends is below 99/100.
    Scene s = test::bundled("harmonic_oscillator");
    const Eigen::VectorXd x0 = vec({std::cos(0.2), std::sin(0.2)});
    const Run coarse = run(s, 4, 0.5, x0, 0.5, {{"q - 99/100", 0, false}});
    CHECK(coarse.crossings.empty());
    const Run sampled = run(s, 4, 0.5, x0, 0.5, {{"q - 99/100", 0, false}}, 4);
    REQUIRE(sampled.crossings.size() == 2);
    // dt = 1/2 and order 4: the local error is ~ dt^5 / 100 ~ 1e-4 in the state, and the crossing is
    // transversal (|dq/dt| = 0.14), so its time is good to ~1e-3
    CHECK(std::abs(sampled.crossings[0].t - (0.2 - std::acos(0.99))) < 1e-3);
    CHECK(std::abs(sampled.crossings[1].t - (0.2 + std::acos(0.99))) < 1e-3);
}

TEST_CASE("events: the rigid body's section x2 = 0 (rising) against a fine reference, with its order") {
    // For each crossing the reference state at t_c (RK4, step <= 1e-3: error ~1e-12 at T = 30) gives
    // the exact crossing time by one Newton step t* = t_c - g / (grad g . f) (its error is quadratic
    // in t_c - t*, below 1e-14). Order 4 at dt = 0.1 and 0.05: the errors fall by ~16.
    Scene s = test::bundled("rigid_body");
    const CompiledMap f = CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), s.phase_space().coordinate_vars());
    const Eigen::VectorXd x0 = vec(*s.x0);
    std::vector<double> time_errors, state_errors;
    std::size_t count = 0;
    for (double dt : {0.1, 0.05}) {
        const Run r = run(s, 4, dt, x0, 30, {{"x2", +1, false}});
        REQUIRE(r.crossings.size() >= 3);
        if (count) CHECK(r.crossings.size() == count);
        count = r.crossings.size();
        double time_error = 0, state_error = 0;
        for (const Crossing& c : r.crossings) {
            CHECK(std::abs(c.x(1)) <= 1e-15);
            const Eigen::VectorXd y = flow(f, x0, c.t, 1e-3);
            Eigen::VectorXd fy(3);
            f.eval(y.data(), fy.data());
            const double t_exact = c.t - y(1) / fy(1);
            time_error = std::max(time_error, std::abs(c.t - t_exact));
            state_error = std::max(state_error, (c.x - y).lpNorm<Eigen::Infinity>());
        }
        time_errors.push_back(time_error);
        state_errors.push_back(state_error);
        INFO("rigid body dt = " << dt << ": " << count << " crossings, time error " << time_error << ", state error "
                                << state_error);
    }
    CHECK(time_errors[0] / time_errors[1] >= 0.8 * 16);
    CHECK(time_errors[0] / time_errors[1] <= 1.25 * 16);
    CHECK(state_errors[0] / state_errors[1] >= 0.8 * 16);
    CHECK(state_errors[0] / state_errors[1] <= 1.25 * 16);
}

TEST_CASE("events: crossing states are partial steps, on the leaf, where the dense output is not") {
    // The rigid body's section x2 = 0 over 200 time units at k = 4, dt = 0.2: each crossing's state keeps
    // |x|^2 as the run's steps do, a round-off random walk over at most 1000 steps (~u sqrt(1000) = 3.5e-15; 2e-14
    // holds it), and lies on g = 0 to round-off. The dense output at the same crossing times (the state before)
    // is off the leaf by its local error, ~dt^5 |x| = 3e-4 times a constant: far above round-off.
    Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = vec(*s.x0);
    const double dt = 0.2, C0 = x0.squaredNorm();
    const Run r = run(s, 4, dt, x0, 200, {{"x2", +1, false}});
    REQUIRE(r.crossings.size() >= 10);
    double on_leaf = 0;
    for (const Crossing& c : r.crossings) {
        CHECK(std::abs(c.x(1)) <= 1e-15);
        on_leaf = std::max(on_leaf, std::abs(c.x.squaredNorm() - C0) / C0);
    }
    // the same crossings located on the dense output alone (a detector that does not step)
    StepOptions opt;
    opt.k = 4, opt.dt = dt;
    NewtonStepper st = NewtonStepper::build(s.pi, s.H, opt, x0);
    EventDetector dense(EventSet::build(s.phase_space(), {{"x2", +1, false}}), DenseOutput::build(s.pi, s.H, 4));
    Eigen::VectorXd x = x0, increment(3);
    dense.start(x);
    double off_leaf = 0;
    std::size_t count = 0;
    for (std::size_t n = 1; n <= 1000; ++n) {
        REQUIRE(st.step(x, increment) == StepStatus::ok);
        const Eigen::VectorXd y = x + increment;
        for (const Crossing& c : dense.advance(x, y, double(n - 1) * dt, dt, n))
            off_leaf = std::max(off_leaf, std::abs(c.x.squaredNorm() - C0) / C0), ++count;
        x = y;
    }
    INFO("Casimir error at the crossings: " << on_leaf << " by partial steps, " << off_leaf << " on the dense output");
    CHECK(count == r.crossings.size());
    CHECK(on_leaf <= 2e-14);
    CHECK(off_leaf >= 1e-10);
}

TEST_CASE("events: bad event polynomials are refused with the event and the problem") {
    Scene s = test::bundled("harmonic_oscillator");
    const PhaseSpace& M = s.phase_space();
    try {
        (void)EventSet::build(M, {{"q", 0, false}, {"q + w", 0, false}});
        FAIL("an unknown variable was accepted");
    } catch (const ParseError& e) {
        const std::string what = e.what();
        CHECK(what.rfind("event 2: malformed polynomial 'q + w': unknown variable 'w'", 0) == 0);
    }
    CHECK_THROWS_WITH_AS((void)EventSet::build(M, {{"3/2", 0, false}}),
                         "event 1: '3/2' is constant, it never crosses zero", std::invalid_argument);
    CHECK_THROWS_WITH_AS((void)EventSet::build(M, {{"q", 2, false}}), "event 1: direction 2 is not -1, 0 or 1",
                         std::invalid_argument);
}
