// The realisation evaluators in double: the so(3)* closed form against the Bernoulli series (docs/math.md 3).
#include "poisson/realisation_eval.hpp"
#include "poisson/log_canonical.ipp"  // expm1_near, which the lane step's acceptance test uses
#include "lie_reference.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace pgi;
using pgi::test::structure;

namespace {

double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
    return (a - b).lpNorm<Eigen::Infinity>() / std::max(b.lpNorm<Eigen::Infinity>(), 1e-300);
}

// The closed form's values a against the series' b: alpha, delta and their derivatives to a few ulps of the largest
// entry (alpha_p sums one more product of L's powers: 1e-13).
void check_same_values(const RealisationValues& a, const RealisationValues& b) {
    CHECK(relative_difference(a.alpha, b.alpha) < 1e-14);
    CHECK(relative_difference(a.delta, b.delta) < 1e-14);
    CHECK(relative_difference(a.alpha_x, b.alpha_x) < 1e-14);
    CHECK(relative_difference(a.alpha_p, b.alpha_p) < 1e-13);
    CHECK(relative_difference(a.delta_x, b.delta_x) < 1e-14);
    CHECK(relative_difference(a.delta_p, b.delta_p) < 1e-14);
}

}  // namespace

TEST_CASE("realisation_eval: the so(3)* closed form equals the Bernoulli series, every block, |L| from 1e-8 to 2.5") {
    // the rigid body's bracket and a rescaled, reoriented one (still skew C_j)
    for (const auto& pi : {test::bundled("rigid_body").pi,
                           structure({"x1", "x2", "x3"}, {{0, 1, "2*x3"}, {1, 2, "2*x1"}, {2, 0, "2*x2"}})}) {
        REQUIRE(RealisationEvaluator::has_rotation_form(pi));
        const auto closed = RealisationEvaluator::rotation(pi);
        // the series to degree 60: its tail at |L| = 2.5 is ~(2.5 / 2 pi)^60 < 1e-23
        const auto series = RealisationEvaluator::lie_poisson(pi, 60);
        std::mt19937 gen(3);
        std::normal_distribution<double> normal;
        // theta = |L|: each series branch of h (s = theta^2 up to 1/4, 1 and 4, and their ends) and the closed form
        for (double theta : {1e-8, 1e-3, 0.3, 0.5, 0.7, 1.0, 1.2, 1.99, 2.01, 2.5}) {
            CAPTURE(theta);
            const Eigen::Vector3d x(normal(gen), normal(gen), normal(gen));
            Eigen::Vector3d p(normal(gen), normal(gen), normal(gen));
            RealisationValues a(3), b(3);
            closed.eval(x, p, a);  // to read |L(p)|, then rescale p to the wanted theta
            const double s_now = 0.5 * (a.delta_x).squaredNorm();
            p *= theta / std::sqrt(s_now);
            closed.eval(x, p, a);
            series.eval(x, p, b);
            check_same_values(a, b);
        }
    }
}

TEST_CASE("realisation_eval: the closed form is offered only for skew structure matrices on three coordinates") {
    // [e1, e2] = e2, [e1, e3] = e3: a Lie algebra whose L(p) is not skew
    const auto book = structure({"x1", "x2", "x3"}, {{0, 1, "x2"}, {0, 2, "x3"}});
    CHECK(book.structure_class() == StructureClass::linear);
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(book));
    CHECK_THROWS_AS(RealisationEvaluator::rotation(book), std::invalid_argument);
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(test::bundled("lotka_volterra").pi));
    // so(3)* whose bracket holds a fourth coordinate w (its row zero): C_j is not zero off the three
    const auto held = structure({"x1", "x2", "x3", "w"}, {{0, 1, "-x3 + w"}, {1, 2, "-x1"}, {2, 0, "-x2"}});
    CHECK(held.structure_class() == StructureClass::linear);
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(held));
    // e(3)*: six non-zero rows
    const auto e3 = structure({"m1", "m2", "m3", "g1", "g2", "g3"}, {{0, 1, "m3"},
                                                                    {1, 2, "m1"},
                                                                    {2, 0, "m2"},
                                                                    {0, 4, "g3"},
                                                                    {0, 5, "-g2"},
                                                                    {1, 5, "g1"},
                                                                    {1, 3, "-g3"},
                                                                    {2, 3, "g2"},
                                                                    {2, 4, "-g1"}});
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(e3));
}

TEST_CASE("realisation_eval: the so(3)* closed form with zero-row coordinates equals the series and leaves them alone") {
    // so(3)* on x1, x2, x3 with w1, w2 interleaved (their rows zero: Casimirs, as a scheme's parameters are), so the
    // three coordinates' indices are read, not assumed; the series on the whole structure is the reference
    const auto pi = structure({"w1", "x1", "x2", "w2", "x3"}, {{1, 2, "-x3"}, {2, 4, "-x1"}, {4, 1, "-x2"}});
    REQUIRE(RealisationEvaluator::has_rotation_form(pi));
    const auto closed = RealisationEvaluator::rotation(pi);
    const auto series = RealisationEvaluator::lie_poisson(pi, 60);
    std::mt19937 gen(34);
    std::normal_distribution<double> normal;
    for (double theta : {1e-3, 1.0, 2.5}) {  // |L|: h's short and long series, and its closed form
        CAPTURE(theta);
        Eigen::VectorXd x(5), p(5);
        for (Eigen::Index i = 0; i < 5; ++i) x[i] = normal(gen), p[i] = normal(gen);
        RealisationValues a(5), b(5);
        closed.eval(x, p, a);
        p *= theta / std::sqrt(0.5 * a.delta_x.squaredNorm());
        closed.eval(x, p, a);
        series.eval(x, p, b);
        check_same_values(a, b);  // as in dimension 3: the same sums on the three coordinates
        RealisationCheck c(5);
        closed.check(x, p, c);
        Eigen::VectorXd delta(5);
        closed.delta(x, p, delta);
        CHECK(c.alpha == a.alpha);
        CHECK(c.delta == a.delta);
        CHECK(delta == a.delta);
        for (const Eigen::Index w : {0, 3}) {  // exactly: alpha_w = x_w, delta_w = 0, and p_w enters nothing
            CAPTURE(w);
            CHECK(a.alpha[w] == x[w]);
            CHECK(a.delta[w] == 0);
            CHECK(a.alpha_x.row(w) == Eigen::RowVectorXd::Unit(5, w));
            CHECK(a.alpha_p.row(w).isZero(0));
            CHECK(a.alpha_p.col(w).isZero(0));
            CHECK(a.delta_x.row(w).isZero(0));
            CHECK(a.delta_p.col(w).isZero(0));
            CHECK(c.shift[w] == 0);
            CHECK(c.size[w] == std::abs(x[w]));
        }
    }
}

// issue 11.9 / 16.1
TEST_CASE("the Lie-Poisson evaluator equals g(L(p)) x in long double, inside and beyond its series' radius") {
    // sl(2)* ({h,e} = 2e, {h,f} = -2f, {e,f} = h: real and imaginary spectra), e(3)* (defective L) and the
    // book algebra ({x1,x2} = x2, {x1,x3} = x3: L not skew), at |L|_inf from 0.1 to past the series radius
    // of D = 24 (1.38) to spectral radii near 0.8 * 2 pi. alpha is compared at round-off relative to the
    // size of its terms (|x| + |g(L)| |x|), 1e-14; alpha_p against central differences of the reference
    // (h = 1e-5 |p|: truncation h^2 |alpha'''| ~ 1e-10, round-off 1e-19 / h), 1e-8.
    const std::vector<PoissonStructure> algebras{
        structure({"h", "e", "f"}, {{0, 1, "2*e"}, {0, 2, "-2*f"}, {1, 2, "h"}}),
        structure({"m1", "m2", "m3", "g1", "g2", "g3"}, {{0, 1, "m3"},
                                                         {1, 2, "m1"},
                                                         {2, 0, "m2"},
                                                         {0, 4, "g3"},
                                                         {0, 5, "-g2"},
                                                         {1, 5, "g1"},
                                                         {1, 3, "-g3"},
                                                         {2, 3, "g2"},
                                                         {2, 4, "-g1"}}),
        structure({"x1", "x2", "x3"}, {{0, 1, "x2"}, {0, 2, "x3"}})};
    std::mt19937 gen(11);
    std::normal_distribution<double> normal;
    for (const auto& pi : algebras) {
        const auto n = static_cast<Eigen::Index>(pi.dim());
        const auto e = RealisationEvaluator::lie_poisson(pi, 24);
        const test::LongDoubleLie ref(e, n);
        for (double target : {0.1, 1.0, 2.0, 4.0, 6.0}) {
            Eigen::VectorXd x(n), p(n);
            for (Eigen::Index i = 0; i < n; ++i) x[i] = normal(gen), p[i] = normal(gen);
            p *= target / e.operator_norm_at(p);
            RealisationValues v(pi.dim());
            e.eval(x, p, v);
            // the reference converges only for spectral radii below 2 pi: skip the points beyond (rare)
            const Eigen::MatrixXcd L = v.delta_x;
            if (L.eigenvalues().cwiseAbs().maxCoeff() > 0.8 * 2 * M_PI) continue;
            CAPTURE(pi.dim());
            CAPTURE(target);
            const auto exact = ref.alpha(x.cast<long double>(), p.cast<long double>());
            const double size = x.lpNorm<Eigen::Infinity>() + (v.alpha_x.cwiseAbs() * x.cwiseAbs()).maxCoeff();
            CHECK(double((v.alpha.cast<long double>() - exact).cwiseAbs().maxCoeff()) / size < 1e-14);
            RealisationCheck c(pi.dim());
            e.check(x, p, c);
            CHECK((c.alpha - v.alpha).lpNorm<Eigen::Infinity>() / size < 1e-14);
            for (Eigen::Index j = 0; j < n; ++j) {
                const long double h = 1e-5L * p.lpNorm<Eigen::Infinity>();
                Eigen::Matrix<long double, -1, 1> pp = p.cast<long double>(), pm = pp;
                pp[j] += h, pm[j] -= h;
                const Eigen::VectorXd fd =
                    ((ref.alpha(x.cast<long double>(), pp) - ref.alpha(x.cast<long double>(), pm)) / (2 * h))
                        .cast<double>();
                CHECK((v.alpha_p.col(j) - fd).lpNorm<Eigen::Infinity>() / (size / p.lpNorm<Eigen::Infinity>()) < 1e-8);
            }
        }
    }
}

TEST_CASE(
    "log-canonical: e^(u/2) - 1 from a nearby exponent is expm1's to a few ulps of the nearby value; farther away it "
    "is expm1's") {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> exponent(-3, 3), unit(-1, 1);
    std::uniform_int_distribution<int> scale(0, 9), shift(19, 60);
    const double ulp = std::numeric_limits<double>::epsilon();
    int near = 0;
    for (int i = 0; i < 20000; ++i) {
        // u0 over several scales (e^(u/2) - 1 keeps its relative accuracy near 0), u moved by up to 2^-19 (d up to
        // 2^-20)
        const double u0 = exponent(rng) * std::pow(10.0, -double(scale(rng))),
                     u = u0 + std::ldexp(unit(rng), -shift(rng));
        const double em1_0 = std::expm1(0.5 * u0), want = std::expm1(0.5 * u), got = expm1_near(u, u0, em1_0);
        CAPTURE(u0);
        CAPTURE(u);
        CHECK(std::abs(got - want) <=
              4 * ulp * std::max(std::abs(em1_0), std::abs(want)));  // both libm calls, d and two roundings
        near += std::abs(0.5 * (u - u0)) <= 0x1p-20;
    }
    CHECK(near > 19000);  // the cubic served nearly all of them (a quadratic instead fails where em1 is small)
    // beyond |d| = 2^-20 (and for a NaN exponent) the libm call itself
    for (const double u0 : {-2.0, 0.0, 1e-300, 2.5})
        for (const double step : {0x1p-18, -0x1p-10, 1.0})
            CHECK(expm1_near(u0 + step, u0, std::expm1(0.5 * u0)) == std::expm1(0.5 * (u0 + step)));
    CHECK(std::isnan(expm1_near(std::nan(""), 0.0, 0.0)));
}
