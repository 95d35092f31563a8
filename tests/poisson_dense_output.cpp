// Dense output: the Lie derivatives exactly, the interpolant's end conditions, and its measured order.
#include "poisson/dense_output.hpp"
#include "poisson/newton_step.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace pgi;

namespace {

Eigen::VectorXd vec(const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

// Classical RK4 on the compiled field with many small steps: the reference flow (error ~ h^4 t, below 1e-16 here).
Eigen::VectorXd flow(const Scene& s, Eigen::VectorXd x, double t, std::size_t N = 2000) {
    const CompiledMap f = CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), s.phase_space().coordinate_vars());
    auto F = [&](const Eigen::VectorXd& y) {
        Eigen::VectorXd r(y.size());
        f.eval(y.data(), r.data());
        return r;
    };
    const double h = t / double(N);
    for (std::size_t n = 0; n < N; ++n) {
        Eigen::VectorXd k1 = F(x), k2 = F(x + 0.5 * h * k1), k3 = F(x + 0.5 * h * k2), k4 = F(x + h * k3);
        x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return x;
}

double slope(const std::vector<double>& dts, const std::vector<double>& errors) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double m = double(dts.size());
    for (std::size_t i = 0; i < dts.size(); ++i) {
        const double x = std::log(dts[i]), y = std::log(errors[i]);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    return (m * sxy - sx * sy) / (m * sxx - sx * sx);
}

// Mid-step error of one step's dense output, and the step's own local error, against the reference flow.
struct LocalErrors {
    std::vector<double> dts, mid, end;
};

LocalErrors local_errors(const Scene& s, std::size_t k, std::size_t dense_order, const std::vector<double>& dts) {
    const Eigen::VectorXd x0 = vec(*s.x0);
    DenseOutput d = DenseOutput::build(s.pi, s.H, dense_order);
    LocalErrors e;
    for (double dt : dts) {
        StepOptions opt;
        opt.k = k;
        opt.dt = dt;
        NewtonStepper st = NewtonStepper::build(s.pi, s.H, opt, x0);
        Eigen::VectorXd inc(x0.size()), y(x0.size());
        REQUIRE(st.step(x0, inc) == StepStatus::ok);
        const Eigen::VectorXd x1 = x0 + inc;
        d.fit(x0, x1, dt);
        d.eval(0.5, y.data());
        e.dts.push_back(dt);
        e.mid.push_back((y - flow(s, x0, dt / 2)).lpNorm<Eigen::Infinity>());
        e.end.push_back((x1 - flow(s, x0, dt)).lpNorm<Eigen::Infinity>());
    }
    return e;
}

}  // namespace

TEST_CASE("dense_output: the Lie derivatives of the oscillator's flow, exactly") {
    Scene s = test::bundled("harmonic_oscillator");  // {q, p} = 1, H = (q^2 + p^2)/2: q' = p, p' = -q
    const PhaseSpace& M = s.phase_space();
    const auto L = lie_derivatives(s.pi, s.H, 4);
    REQUIRE(L.size() == 4);
    const Poly q = M.x_gen(0), p = M.x_gen(1);
    CHECK(L[0][0] == p);
    CHECK(L[0][1] == -q);
    CHECK(L[1][0] == -q);
    CHECK(L[1][1] == -p);
    CHECK(L[2][0] == -p);
    CHECK(L[3][0] == q);
    CHECK(L[3][1] == p);
}

TEST_CASE("dense_output: end conditions (value and derivatives at theta = 0 and 1)") {
    Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = vec(*s.x0);
    const double dt = 0.1;
    StepOptions opt;
    opt.k = 4;
    opt.dt = dt;
    NewtonStepper st = NewtonStepper::build(s.pi, s.H, opt, x0);
    Eigen::VectorXd inc(3), y(3), dy(3), f0(3), f1(3);
    REQUIRE(st.step(x0, inc) == StepStatus::ok);
    const Eigen::VectorXd x1 = x0 + inc;
    DenseOutput d = DenseOutput::build(s.pi, s.H, st.order());
    CHECK(d.derivatives() == 2);
    CHECK(d.degree() == 5);
    d.fit(x0, x1, dt);
    const CompiledMap f = CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), s.phase_space().coordinate_vars());
    f.eval(x0.data(), f0.data());
    f.eval(x1.data(), f1.data());
    d.eval(0, y.data());
    CHECK(y == x0);  // theta = 0 adds nothing to x0
    d.eval(1, y.data());
    CHECK((y - x1).lpNorm<Eigen::Infinity>() <= 4e-16);  // the coefficients sum to x1 - x0 up to a few roundings
    d.eval_derivative(0, dy.data());
    CHECK((dy - dt * f0).lpNorm<Eigen::Infinity>() <= 1e-16);
    d.eval_derivative(1, dy.data());
    CHECK((dy - dt * f1).lpNorm<Eigen::Infinity>() <= 1e-15);
}

TEST_CASE("dense_output: interpolating the exact flow, the error at mid-step falls like dt^(2m+2)") {
    // End points on the reference flow: what is left is the interpolation error of the degree-(2m+1)
    // Hermite polynomial, O(dt^(2m+2)). Points below 1e-13 (round-off of the references) are dropped.
    for (const std::string name : {"harmonic_oscillator", "rigid_body", "henon_heiles"}) {
        Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = vec(*s.x0);
        for (std::size_t m = 1; m <= 3; ++m) {
            DenseOutput d = DenseOutput::build(s.pi, s.H, 2 * m);
            std::vector<double> dts, errors;
            for (double dt : {1.6, 0.8, 0.4, 0.2, 0.1}) {
                Eigen::VectorXd y(x0.size());
                d.fit(x0, flow(s, x0, dt), dt);
                d.eval(0.5, y.data());
                const double e = (y - flow(s, x0, dt / 2)).lpNorm<Eigen::Infinity>();
                if (e < 1e-13) continue;
                dts.push_back(dt);
                errors.push_back(e);
            }
            REQUIRE(dts.size() >= 3);
            const double order = slope(dts, errors);
            INFO(name << ", m = " << m << ": slope " << order);
            CHECK(order >= double(2 * m + 2) - 0.3);
            CHECK(order <= double(2 * m + 2) + 0.6);
        }
    }
}

TEST_CASE("dense_output: the local error at mid-step has the step's order p + 1, and half its size") {
    // With m = p/2 the interpolation error O(dt^(p+2)) is below the step's local error O(dt^(p+1)),
    // which the Hermite basis carries to mid-step with weight 1/2: the dense output is as accurate as
    // the step (ratio measured 0.50-0.51; asserted at most 0.6 at every dt).
    for (const std::string name : {"harmonic_oscillator", "rigid_body", "henon_heiles", "lotka_volterra"}) {
        Scene s = test::bundled(name);
        for (std::size_t k = 1; k <= 6; ++k) {
            const std::size_t p = 2 * ((k + 1) / 2);
            const LocalErrors e = local_errors(s, k, p, {0.4, 0.2, 0.1, 0.05});
            const double order = slope(e.dts, e.mid);
            INFO(name << ", k = " << k << ": mid-step slope " << order << ", errors " << e.mid.front() << " .. "
                      << e.mid.back());
            CHECK(order >= double(p + 1) - 0.2);
            CHECK(order <= double(p + 1) + 0.3);
            for (std::size_t i = 0; i < e.dts.size(); ++i) CHECK(e.mid[i] <= 0.6 * e.end[i]);
        }
    }
}

TEST_CASE("dense_output: cubic Hermite is not enough for order 4 (its mid-step error falls like dt^4, not dt^5)") {
    Scene s = test::bundled("rigid_body");
    const LocalErrors cubic = local_errors(s, 4, 2, {0.4, 0.2, 0.1, 0.05});
    const LocalErrors quintic = local_errors(s, 4, 4, {0.4, 0.2, 0.1, 0.05});
    const double cubic_order = slope(cubic.dts, cubic.mid), quintic_order = slope(quintic.dts, quintic.mid);
    INFO("cubic " << cubic_order << ", quintic " << quintic_order);
    CHECK(cubic_order < 4.3);
    CHECK(quintic_order > 4.8);
    CHECK(cubic.mid.back() > 5 * cubic.end.back());  // worse than the step it extends (15x measured)
}

TEST_CASE("dense_output: a fit reusing the previous end's derivatives equals a fresh fit, bit for bit") {
    Scene s = test::bundled("henon_heiles");
    const Eigen::VectorXd x0 = vec(*s.x0);
    StepOptions opt;
    opt.k = 6;
    opt.dt = 0.1;
    NewtonStepper st = NewtonStepper::build(s.pi, s.H, opt, x0);
    Eigen::VectorXd inc(4), y(4), z(4);
    REQUIRE(st.step(x0, inc) == StepStatus::ok);
    const Eigen::VectorXd x1 = x0 + inc;
    REQUIRE(st.step(x1, inc) == StepStatus::ok);
    const Eigen::VectorXd x2 = x1 + inc;
    DenseOutput chained = DenseOutput::build(s.pi, s.H, st.order()), fresh = chained;
    chained.fit(x0, x1, 0.1);
    chained.fit(x1, x2, 0.1);  // reuses the derivatives at x1
    fresh.fit(x1, x2, 0.1);
    for (double theta : {0.0, 0.3, 0.7, 1.0}) {
        chained.eval(theta, y.data());
        fresh.eval(theta, z.data());
        CHECK(y == z);
    }
}
