// Output at requested times (pgi::integrate with t_eval, scheme/detail/time_output.hpp): each row is the run's own
// state or a true partial step of the same method from the state before it, the run itself is unchanged, and every row
// keeps the Casimirs to round-off.
#include "scheme/trajectory.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using namespace pgi;

namespace {

Eigen::VectorXd start(const Scene& s) {
    return Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
}

Eigen::VectorXd row(const Trajectory& r, std::size_t k) {
    return Eigen::Map<const Eigen::VectorXd>(r.x.data() + k * r.dim, Eigen::Index(r.dim));
}

}  // namespace

TEST_CASE("t_eval: each row is the run's state or one partial step from the state before, the run unchanged") {
    for (const std::string name : {"rigid_body", "lotka_volterra", "volterra_chain", "henon_heiles"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = start(s);
        const double dt = s.dt, t_end = 50 * dt;
        const Trajectory plain = integrate(*s.scheme, x0, dt, t_end, 1, std::nullopt, {}, {}, {}, true);
        REQUIRE(plain.status == StepStatus::ok);
        // the start, inside the first step, a step's own time, between steps, and t_end
        const std::vector<double> times = {0.0, 0.25 * dt, 3 * dt, 7.5 * dt, 10.01 * dt, 49.9 * dt, t_end};
        const Trajectory r = integrate(*s.scheme, x0, dt, t_end, 1, std::nullopt, {}, {}, {}, true, times);
        REQUIRE(r.status == StepStatus::ok);
        CHECK(r.t == times);  // exactly the requested times
        REQUIRE(r.x.size() == times.size() * r.dim);
        CHECK(r.steps == plain.steps);
        CHECK(r.jacobian == plain.jacobian);           // the same steps, bit for bit
        NewtonStepper st = s.scheme->stepper(dt, x0);  // the run's compiled step (built at x0)
        Eigen::VectorXd increment(x0.size());
        for (std::size_t k = 0; k < times.size(); ++k) {
            CAPTURE(times[k]);
            const auto n = std::size_t(std::floor(times[k] / dt + 1e-9));
            const Eigen::VectorXd from = row(plain, n);
            Eigen::VectorXd expected = from;
            const double h = times[k] - double(n) * dt;
            if (std::abs(h) > 1e-12 * dt) {
                REQUIRE(st.step(from, h, increment) == StepStatus::ok);
                expected = from + increment;
            }
            CHECK(row(r, k) == expected);
        }
    }
}

TEST_CASE("t_eval: rows between steps keep the Casimirs to round-off") {
    // 400 requested times off the step grid over 1000 steps: each row's Casimir error is that of a run of at most
    // 1000 steps plus one, a round-off random walk of a few u per step (~u sqrt(1000) = 3.5e-15); 2e-14 holds it
    // with room, where an interpolant of order 4 between steps at these dt errs by 1e-7 and more.
    for (const std::string name : {"rigid_body", "lotka_volterra", "volterra_chain"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const double dt = s.dt, t_end = 1000 * dt;
        std::vector<double> times;
        for (int k = 0; k < 400; ++k) times.push_back((2.5 * k + 0.37) * dt);
        const Trajectory r = integrate(*s.scheme, start(s), dt, t_end, 1, std::nullopt, {}, {}, {}, false, times);
        REQUIRE(r.status == StepStatus::ok);
        REQUIRE(r.t.size() == times.size());
        REQUIRE(!r.casimir_error.empty());
        double worst = 0;
        for (const double e : r.casimir_error) worst = std::max(worst, e);
        CHECK(worst <= 2e-14);
        CHECK(r.casimir_error_max[0] <= 2e-14);
    }
}

TEST_CASE("t_eval: times outside [0, t_end], not increasing or not finite are refused before any work") {
    const Scene s = test::bundled("rigid_body");
    for (const std::vector<double>& times :
         {std::vector<double>{-0.1}, {0.5, 0.2}, {0.3, 0.3}, {std::nan("")}, {1.0 + 1e-9}, {HUGE_VAL}}) {
        CAPTURE(times[0]);
        try {
            (void)integrate(*s.scheme, start(s), s.dt, 1.0, 1, std::nullopt, {}, {}, {}, false, times);
            FAIL("accepted");
        } catch (const InputError& e) {
            CHECK(e.key() == "t_eval");
        }
    }
}
