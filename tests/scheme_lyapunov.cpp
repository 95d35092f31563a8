// Lyapunov exponents by Benettin's method on the exact step Jacobian (scheme/lyapunov.hpp): the leaf's exponents
// in (+l, -l) pairs summing to round-off, the Casimirs' directions at exactly 0, the records, and bad input.
#include "scheme/lyapunov.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace pgi;

namespace {

Eigen::VectorXd start(const Scene& s) {
    return Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
}

}  // namespace

TEST_CASE("lyapunov: on a leaf of constant area the exponents pair up, across it they are 0") {
    // the rigid body near its unstable (middle) axis: the leaf is a sphere, on which the step keeps the area form
    const Scene s = test::bundled("rigid_body");
    Eigen::VectorXd x0(3);
    x0 << 0.01, 0.99, 0.01;
    const LyapunovSpectrum l = lyapunov(*s.scheme, x0, 0.1, 200.0, 500);
    REQUIRE(l.status == StepStatus::ok);
    CHECK(l.leaf_dim == 2);
    REQUIRE(l.spectrum.size() == 3);
    CHECK(l.spectrum[2] == 0.0);  // across the leaf: reported exactly 0
    CAPTURE(l.spectrum[0]);
    CAPTURE(l.spectrum[1]);
    CHECK(l.spectrum[0] > 0);  // near a homoclinic orbit: separation grows over t = 200
    CHECK(std::abs(l.spectrum[0] + l.spectrum[1]) <= 1e-12);
    // records every 500 steps and the last: t = 50, 100, 150, 200
    CHECK(l.t == std::vector<double>{50.0, 100.0, 150.0, 200.0});
    CHECK(l.exponents.size() == 4 * 3);
    CHECK(l.steps == 2000);
}

TEST_CASE("lyapunov: a canonical system's exponents sum to 0 to round-off and pair up (Henon-Heiles, chaotic)") {
    // E = 1/6, on the section q1 = 0 at q2 = -1/4, p2 = 0: in the chaotic sea
    const Scene s = test::bundled("henon_heiles");
    const double q2 = -0.25;
    Eigen::VectorXd x0(4);
    x0 << 0.0, q2, std::sqrt(2 * (1.0 / 6 - q2 * q2 / 2 + q2 * q2 * q2 / 3)), 0.0;
    const LyapunovSpectrum l = lyapunov(*s.scheme, x0, 0.1, 2000.0, 20000);
    REQUIRE(l.status == StepStatus::ok);
    CHECK(l.leaf_dim == 4);
    double sum = 0;
    for (double e : l.spectrum) sum += e;
    CAPTURE(sum);
    CHECK(std::abs(sum) <= 1e-12);  // det J = 1 for every step: the sum of log |R_ii| is round-off
    // the largest well apart from the rest, and paired with the smallest up to O(1/t)
    CAPTURE(l.spectrum[0]);
    CAPTURE(l.spectrum[3]);
    CHECK(l.spectrum[0] > 0.1);
    CHECK(std::abs(l.spectrum[1]) < 0.01);
    CHECK(std::abs(l.spectrum[0] + l.spectrum[3]) <= 0.01 * l.spectrum[0]);
}

TEST_CASE("lyapunov: bad input is an InputError naming the argument") {
    const Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = start(s);
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, x0, 0.1, 1.0, 0), doctest::Contains("every"), InputError);
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, Eigen::VectorXd::Zero(2), 0.1, 1.0), doctest::Contains("x0"), InputError);
    Eigen::VectorXd nan = x0;
    nan[0] = std::nan("");
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, nan, 0.1, 1.0), doctest::Contains("x0"), InputError);
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, x0, -0.1, 1.0), doctest::Contains("dt"), InputError);
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, x0, 0.1, 0.0), doctest::Contains("t_end"), InputError);
    // at the origin the Casimir's gradient vanishes: no leaf to be tangent to
    CHECK_THROWS_WITH_AS(lyapunov(*s.scheme, Eigen::VectorXd::Zero(3), 0.1, 1.0), doctest::Contains("x0"), InputError);
}
