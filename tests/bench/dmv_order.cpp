// The discrete Moser-Veselov peer (tools/bench/dmv.*) reaches its order: the fitted slope of log error
// against log h on the free rigid body is within 0.5 of 2, 4, ..., 10, against a long double Fehlberg
// 7(8) reference written here (independent of pgi and of the peer). A wrong coefficient of the modified
// inertia at h^(2j) drops the order to 2j, so the slope test catches it. Also: |m| is kept to round-off
// (the update is a rotation), and a step too large for the stage's iteration is an error, not a state.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include "tools/bench/dmv.hpp"

#include <boost/numeric/odeint.hpp>
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace {

using pgi::bench::Dmv;
using pgi::bench::Vec3;
using LState = std::array<long double, 3>;

const Vec3 inertia{2.0, 1.0, 2.0 / 3.0};  // tools/scenes/rigid_body.toml
const Vec3 m0{0.4535961214255773, 0.0, 0.8912073600614354};

Vec3 reference(double T) {
    LState y{m0[0], m0[1], m0[2]};
    auto rhs = [](const LState& m, LState& d, long double) {
        const LState w{m[0] / inertia[0], m[1] / inertia[1], m[2] / inertia[2]};
        d = {m[1] * w[2] - m[2] * w[1], m[2] * w[0] - m[0] * w[2], m[0] * w[1] - m[1] * w[0]};
    };
    using namespace boost::numeric::odeint;
    integrate_adaptive(make_controlled(1e-19L, 1e-19L, runge_kutta_fehlberg78<LState, long double>()), rhs, y, 0.0L,
                       static_cast<long double>(T), 0.01L);
    return {double(y[0]), double(y[1]), double(y[2])};
}

double error_at(const Dmv& dmv, double h, double T, const Vec3& ref) {
    Vec3 m = m0;
    for (long n = 0, N = std::lround(T / h); n < N; ++n) dmv.step(m, h);
    double e = 0;
    for (int i = 0; i < 3; ++i) e = std::max(e, std::abs(m[i] - ref[i]));
    return e;
}

// least-squares slope of log e against log h
double fitted_order(const Dmv& dmv, const std::vector<double>& hs, double T, const Vec3& ref) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (double h : hs) {
        const double x = std::log(h), y = std::log(error_at(dmv, h, T, ref));
        sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    const double n = double(hs.size());
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

TEST_CASE("DMV and its preprocessed versions reach orders 2, 4, 6, 8, 10 on the rigid body") {
    const double T = 10;
    const Vec3 ref = reference(T);
    // steps where the error is in the asymptotic range and above round-off (~1e-15) for each order
    const std::vector<std::pair<int, std::vector<double>>> cases{
        {2, {0.2, 0.1, 0.05}}, {4, {0.2, 0.1, 0.05}}, {6, {0.4, 0.2, 0.1}}, {8, {0.4, 0.2, 0.1}}, {10, {0.4, 0.2}}};
    for (const auto& [k, hs] : cases) {
        const int order = k;  // (a name, not a binding: CAPTURE is a lambda)
        CAPTURE(order);
        const double p = fitted_order(Dmv(order, inertia), hs, T, ref);
        CAPTURE(p);
        CHECK(std::abs(p - order) < 0.5);
    }
}

TEST_CASE("DMV keeps |m| to round-off and refuses a step its stage cannot solve") {
    const Dmv dmv(10, inertia);
    Vec3 m = m0;
    const double n0 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
    for (int n = 0; n < 1000; ++n) dmv.step(m, 0.1);
    // 1000 rotations, each exact to a few ulps: the drift is a random walk of ~sqrt(1000) * 1e-16
    CHECK(std::abs(m[0] * m[0] + m[1] * m[1] + m[2] * m[2] - n0) < 1e-13);
    Vec3 big = m0;
    CHECK_THROWS_AS(Dmv(2, inertia).step(big, 50.0), std::runtime_error);
    CHECK_THROWS_AS(Dmv(3, inertia), std::invalid_argument);
}
