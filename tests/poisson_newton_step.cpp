// The compiled step: measured orders, Casimirs over long runs, the Poisson property of one step,
// the midpoint rule, and stiff and extreme cases (docs/math.md 5-6).
#include "poisson/integrate.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <map>

using namespace pgi;

namespace {

Eigen::VectorXd vec(const std::vector<double>& v) { return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())); }

// The vector field pi grad H, compiled: the reference integrator's and the RK4 baseline's right-hand side.
struct VectorField {
    CompiledMap f;
    explicit VectorField(const Scene& s) : f(CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), s.phase_space().coordinate_vars())) {}
    Eigen::VectorXd operator()(const Eigen::VectorXd& x) const {
        Eigen::VectorXd y(x.size());
        f.eval(x.data(), y.data());
        return y;
    }
};

// Classical RK4 (the non-Poisson baseline, and with a tiny step the reference solution).
Eigen::VectorXd rk4(const VectorField& f, Eigen::VectorXd x, double h, std::size_t N) {
    for (std::size_t n = 0; n < N; ++n) {
        Eigen::VectorXd k1 = f(x), k2 = f(x + 0.5 * h * k1), k3 = f(x + 0.5 * h * k2), k4 = f(x + h * k3);
        x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return x;
}

NewtonStepper stepper(const Scene& s, std::size_t k, double dt, const Eigen::VectorXd& x0,
                      RealisationChoice choice = RealisationChoice::automatic) {
    StepOptions opt;
    opt.k = k;
    opt.dt = dt;
    opt.realisation = choice;
    return NewtonStepper::build(s.pi, s.H, opt, x0);
}

Eigen::VectorXd run(NewtonStepper& st, Eigen::VectorXd x, std::size_t N) {
    auto summary = integrate_steps(st, x, N, [](std::size_t, double, const Eigen::VectorXd&) { return false; });
    REQUIRE(summary.status == StepStatus::ok);
    return x;
}

// Least-squares slope of log(error) against log(dt), over the points above the round-off floor.
double fitted_order(const std::vector<double>& dts, const std::vector<double>& errors, double floor) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int m = 0;
    for (std::size_t i = 0; i < dts.size(); ++i) {
        if (errors[i] < floor) continue;
        const double x = std::log(dts[i]), y = std::log(errors[i]);
        sx += x, sy += y, sxx += x * x, sxy += x * y, ++m;
    }
    REQUIRE(m >= 3);
    return (m * sxy - sx * sy) / (m * sxx - sx * sx);
}

}  // namespace

TEST_CASE("newton_step: global order 2 ceil(k/2) for k = 1..6 (rigid body, Lotka-Volterra, Nambu, (x^2+y^2) dx^dy)") {
    // Errors at T = 1 against RK4 with a step 400 times smaller (its error is below 1e-14, far below
    // the errors fitted);
    // points under 1e-12 are dominated by round-off and dropped.
    const double T = 1.0;
    for (const std::string name : {"rigid_body", "lotka_volterra", "nambu", "plane_quadratic"}) {
        Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = vec(*s.x0);
        std::map<int, Eigen::VectorXd> reference;  // by N
        for (int N : {3, 4, 5, 6, 8, 16, 32, 64}) reference[N] = rk4(VectorField(s), x0, T / (N * 400), std::size_t(N) * 400);
        for (std::size_t k = 1; k <= 6; ++k) {
            // dt = T/N; order 6 falls to round-off fast, so its ladder is shorter and denser
            const std::vector<int> steps = k <= 4 ? std::vector<int>{4, 8, 16, 32, 64} : std::vector<int>{3, 4, 5, 6, 8};
            std::vector<double> dts;
            for (int N : steps) dts.push_back(T / N);
            std::vector<double> errors;
            for (int N : steps) {
                auto st = stepper(s, k, T / N, x0);
                errors.push_back((run(st, x0, std::size_t(N)) - reference[N]).lpNorm<Eigen::Infinity>());
            }
            const double expected = 2.0 * double((k + 1) / 2);
            CAPTURE(name);
            CAPTURE(k);
            CAPTURE(errors[0]);
            CAPTURE(errors[2]);
            CAPTURE(errors[4]);
            const double order = fitted_order(dts, errors, 1e-12);
            CHECK(order > expected - 0.3);
            CHECK(order < expected + 0.5);
        }
    }
}

TEST_CASE("newton_step: Casimirs are kept to round-off over 1e5 steps for every k, RK4 drifts") {
    // Relative Casimir error <= 1e-13 for the quadratic (rigid body) and the non-quadratic Casimirs
    // (x1 x2 x3 of the cyclic Lotka-Volterra system, the Nambu cubic); explicit RK4 at the same dt
    // drifts by orders of magnitude more.
    for (const std::string name : {"rigid_body", "lotka_volterra", "nambu"}) {
        Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = vec(*s.x0);
        CompiledMap C = CompiledMap::build(s.casimirs, s.phase_space().coordinate_vars());
        auto casimir = [&](const Eigen::VectorXd& x) {
            double c;
            C.eval(x.data(), &c);
            return c;
        };
        const double C0 = casimir(x0);
        const std::size_t N = 100000;
        for (std::size_t k : {1, 2, 3, 4, 5, 6}) {
            CAPTURE(name);
            CAPTURE(k);
            auto st = stepper(s, k, s.dt, x0);
            double worst = 0;
            Eigen::VectorXd x = x0;
            auto summary = integrate_steps(st, x, N, [&](std::size_t, double, const Eigen::VectorXd& y) {
                worst = std::max(worst, std::abs(casimir(y) - C0) / std::abs(C0));
                return false;
            });
            REQUIRE(summary.status == StepStatus::ok);
            CHECK(summary.steps == N);
            CHECK(worst <= 1e-13);
            CHECK(summary.mean_iterations <= 2.0);
        }
        const double rk4_drift = std::abs(casimir(rk4(VectorField(s), x0, s.dt, N)) - C0) / std::abs(C0);
        CAPTURE(rk4_drift);
        CHECK(rk4_drift > 1e-9);
    }
}

TEST_CASE("newton_step: one step is a Poisson map to round-off, Dphi pi(x) Dphi^T = pi(phi(x)), for every class") {
    for (const std::string name : {"henon_heiles", "rigid_body", "lotka_volterra", "volterra_chain", "nambu", "plane_quadratic"}) {
        Scene s = test::bundled(name);
        const Eigen::VectorXd x = vec(*s.x0);
        const auto n = x.size();
        auto pi_at = [&](const Eigen::VectorXd& y) {
            std::vector<double> point(y.data(), y.data() + n);
            point.resize(2 * std::size_t(n), 0.0);
            Eigen::MatrixXd P(n, n);
            for (Eigen::Index i = 0; i < n; ++i)
                for (Eigen::Index j = 0; j < n; ++j) P(i, j) = evaluate(s.pi(std::size_t(i), std::size_t(j)), point);
            return P;
        };
        for (std::size_t k : {1, 4}) {
            CAPTURE(name);
            CAPTURE(k);
            auto st = stepper(s, k, s.dt, x);
            Eigen::VectorXd inc(n);
            REQUIRE(st.step(x, inc) == StepStatus::ok);
            const Eigen::MatrixXd Dphi = st.tangent_map(x);
            const Eigen::MatrixXd defect = Dphi * pi_at(x) * Dphi.transpose() - pi_at(x + inc);
            const double size = pi_at(x).lpNorm<Eigen::Infinity>() + 1.0;
            CAPTURE(defect.lpNorm<Eigen::Infinity>());
            CHECK(defect.lpNorm<Eigen::Infinity>() <= 1e-14 * size);
            // and the step is not the identity: the check has something to check
            CHECK((Dphi - Eigen::MatrixXd::Identity(n, n)).lpNorm<Eigen::Infinity>() > 1e-3);
        }
    }
}

TEST_CASE("newton_step: k = 1 with constant pi is the implicit midpoint rule") {
    Scene s = test::bundled("henon_heiles");
    const VectorField f(s);
    Eigen::VectorXd x = vec(*s.x0);
    auto st = stepper(s, 1, s.dt, x);
    for (int n = 0; n < 100; ++n) {
        // midpoint: y = x + dt f((x + y)/2), by fixed-point iteration to convergence
        Eigen::VectorXd y = x;
        for (int it = 0; it < 200; ++it) y = x + s.dt * f(0.5 * (x + y));
        Eigen::VectorXd inc(x.size());
        REQUIRE(st.step(x, inc) == StepStatus::ok);
        CHECK((x + inc - y).lpNorm<Eigen::Infinity>() <= 4e-16 * (1 + y.lpNorm<Eigen::Infinity>()));
        x = y;
    }
}

TEST_CASE("newton_step: stiff oscillator, omega dt = 10, 100, 1000: bounded with energy kept for every k") {
    // H = (q^2 + p^2)/2 is quadratic, so S_dt = tau(dt) H and the step is the midpoint rule (a Cayley
    // transform, unitary) with the modified step tau: bounded whatever dt, the phase meaningless.
    Scene s = test::bundled("harmonic_oscillator");
    const Eigen::VectorXd x0 = vec(*s.x0);
    for (double dt : {10.0, 100.0, 1000.0})
        for (std::size_t k : {1, 2, 3, 6}) {
            CAPTURE(dt);
            CAPTURE(k);
            auto st = stepper(s, k, dt, x0);
            Eigen::VectorXd x = x0;
            double worst = 0;
            auto summary = integrate_steps(st, x, 1000, [&](std::size_t, double, const Eigen::VectorXd& y) {
                worst = std::max(worst, std::abs(y.squaredNorm() - 1.0));
                return false;
            });
            REQUIRE(summary.status == StepStatus::ok);
            CHECK(worst < 1e-12);
            CHECK(summary.mean_iterations <= 3.0);
        }
}

TEST_CASE("newton_step: Lotka-Volterra orbits passing close to the coordinate planes keep x1 x2 x3 and positivity") {
    Scene s = test::bundled("lotka_volterra");
    for (double small : {1e-4, 1e-8}) {
        Eigen::VectorXd x(3);
        x << small, 2.0, 0.5;
        const double C0 = x.prod();
        auto st = stepper(s, 4, 0.05, x);
        double worst = 0, smallest = 1;
        auto summary = integrate_steps(st, x, 20000, [&](std::size_t, double, const Eigen::VectorXd& y) {
            worst = std::max(worst, std::abs(y.prod() - C0) / C0);
            smallest = std::min(smallest, y.minCoeff());
            return false;
        });
        CAPTURE(small);
        REQUIRE(summary.status == StepStatus::ok);
        CHECK(worst < 1e-13);
        CHECK(smallest > 0);
        CHECK(smallest < 10 * small);  // the orbit does pass close to a plane
    }
}

TEST_CASE("newton_step: states of size 1e6 and 1e-6 keep the Casimir to round-off") {
    Scene s = test::bundled("rigid_body");
    for (double size : {1e6, 1e-6}) {
        const Eigen::VectorXd x0 = size * vec(*s.x0);
        // the rigid body's time scales like 1/|x|: dt = 0.1/|x| gives the same dynamics as dt = 0.1 at |x| = 1
        const double dt = 0.1 / size;
        auto st = stepper(s, 4, dt, x0);
        Eigen::VectorXd x = x0;
        double worst = 0;
        auto summary = integrate_steps(st, x, 10000, [&](std::size_t, double, const Eigen::VectorXd& y) {
            worst = std::max(worst, std::abs(y.squaredNorm() / x0.squaredNorm() - 1.0));
            return false;
        });
        CAPTURE(size);
        REQUIRE(summary.status == StepStatus::ok);
        CHECK(worst < 1e-13);
        CHECK((x - x0).norm() > 1e-3 * x0.norm());  // it moved
    }
}

TEST_CASE("newton_step: dt = 1e-8 loses nothing to cancellation (increment form)") {
    // x_new - x is computed as (beta - alpha)(xb, p) directly; forming beta then subtracting x would
    // leave a relative error of eps |x| / (dt |f|) ~ 1e-8 in the increment. Here the increment matches
    // dt f + dt^2/2 f' f to 1e-12.
    Scene s = test::bundled("rigid_body");
    const VectorField f(s);
    const Eigen::VectorXd x = vec(*s.x0);
    const double dt = 1e-8;
    for (std::size_t k : {1, 2, 4}) {
        auto st = stepper(s, k, dt, x);
        Eigen::VectorXd inc(3);
        REQUIRE(st.step(x, inc) == StepStatus::ok);
        const Eigen::VectorXd fx = f(x);
        const double h = 1e-4;  // f' f by a central difference, accurate far beyond what dt^2 needs
        const Eigen::VectorXd ffx = (f(x + h * fx) - f(x - h * fx)) / (2 * h);
        const Eigen::VectorXd expected = dt * fx + 0.5 * dt * dt * ffx;
        CAPTURE(k);
        CHECK((inc - expected).norm() <= 1e-12 * dt * fx.norm());
    }
}

TEST_CASE("newton_step: a non-finite state is refused, not stepped") {
    Scene s = test::bundled("rigid_body");
    auto st = stepper(s, 2, 0.1, vec(*s.x0));
    Eigen::VectorXd x = vec(*s.x0), inc(3);
    x[1] = std::nan("");
    CHECK(st.step(x, inc) == StepStatus::non_finite);
    CHECK_THROWS_AS(stepper(s, 2, 0.1, x), std::invalid_argument);
    CHECK_THROWS_AS(stepper(s, 0, 0.1, vec(*s.x0)), std::invalid_argument);
    CHECK_THROWS_AS(stepper(s, 2, -0.1, vec(*s.x0)), std::invalid_argument);
}

TEST_CASE("newton_step: stiff coupled oscillators (frequencies 1e3 and 1, omega dt = 10): the stiff mode is neither damped nor amplified") {
    // The fast mode's energy (p1^2 + 1e6 q1^2)/2 stays within 1e-5 of its start over 1e4 steps for every k,
    // (a BDF method damps such a mode); Newton needs about 3 iterations, the dt-series predictor being poor
    // at omega dt = 10.
    Scene s = test::bundled("stiff_oscillators");
    for (std::size_t k : {1, 2, 4}) {
        Eigen::VectorXd x = vec(*s.x0);
        auto fast = [](const Eigen::VectorXd& y) { return 0.5 * (y[2] * y[2] + 1e6 * y[0] * y[0]); };
        const double E0 = fast(x);
        auto st = stepper(s, k, s.dt, x);
        double lo = 1, hi = 1;
        auto summary = integrate_steps(st, x, 10000, [&](std::size_t, double, const Eigen::VectorXd& y) {
            lo = std::min(lo, fast(y) / E0);
            hi = std::max(hi, fast(y) / E0);
            return false;
        });
        CAPTURE(k);
        REQUIRE(summary.status == StepStatus::ok);
        CHECK(lo > 1 - 1e-5);
        CHECK(hi < 1 + 1e-5);
        CHECK(summary.mean_iterations <= 3.0);
    }
}

TEST_CASE("newton_step: the predictor order follows its cost model, and the iterations it expects are the ones measured") {
    struct Case {
        const char* scene;
        std::size_t k, min_order, max_order;
        double iterations;
    };
    // the rigid body's Newton system is costly (the Bernoulli series with its derivatives): a long
    // predictor and one iteration; the n = 6 lattice's is cheap next to its predictor's terms: order 2
    // and two iterations at k = 2
    for (const Case c : {Case{"rigid_body", 4, 4, 6, 1.0}, Case{"volterra_chain", 2, 1, 3, 2.0}}) {
        CAPTURE(c.scene);
        const Scene s = test::bundled(c.scene);
        NewtonStepper st = stepper(s, c.k, s.dt, vec(*s.x0));
        CHECK(st.info().predictor_order >= c.min_order);
        CHECK(st.info().predictor_order <= c.max_order);
        Eigen::VectorXd x = vec(*s.x0);
        auto summary = integrate_steps(st, x, 200, [](std::size_t, double, const Eigen::VectorXd&) { return false; });
        REQUIRE(summary.status == StepStatus::ok);
        CHECK(summary.mean_iterations == doctest::Approx(c.iterations));
    }
    // an order asked for is the order used
    const Scene s = test::bundled("volterra_chain");
    StepOptions opt;
    opt.k = 2;
    opt.dt = s.dt;
    opt.predictor_order = 6;
    CHECK(NewtonStepper::build(s.pi, s.H, opt, vec(*s.x0)).info().predictor_order == 6);
}

TEST_CASE("newton_step: with the radial realisation a linear H is integrated exactly (S_t = t H), for any k") {
    const Scene s = test::bundled("lotka_volterra");  // H = x1 + x2 + x3
    const VectorField f(s);
    const Eigen::VectorXd x0 = vec(*s.x0);
    const Eigen::VectorXd exact = rk4(f, x0, 1e-4, 100000);  // t = 10; RK4's error ~1e-15 at this step
    for (std::size_t k : {1, 2, 4}) {
        CAPTURE(k);
        NewtonStepper radial = stepper(s, k, 0.1, x0, RealisationChoice::radial);
        NewtonStepper closed = stepper(s, k, 0.1, x0, RealisationChoice::closed_form);
        const double radial_error = (run(radial, x0, 100) - exact).lpNorm<Eigen::Infinity>();
        const double closed_error = (run(closed, x0, 100) - exact).lpNorm<Eigen::Infinity>();
        CHECK(radial_error < 1e-12);   // round-off over 100 steps, whatever the order
        CHECK(closed_error > 1e-6);    // the closed form's truncation error at dt = 0.1, order 2 ceil(k/2)
    }
}
