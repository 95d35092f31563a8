// The realisation evaluators in double: the so(3)* closed form against the Bernoulli series (docs/math.md 3).
#include "poisson/realisation_eval.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <random>

using namespace pgi;
using pgi::test::structure;

namespace {

double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
    return (a - b).lpNorm<Eigen::Infinity>() / std::max(b.lpNorm<Eigen::Infinity>(), 1e-300);
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
        // theta = |L|: the series branch of h (s = theta^2 <= 4) and the closed-form branch
        for (double theta : {1e-8, 1e-3, 0.3, 1.0, 1.99, 2.01, 2.5}) {
            CAPTURE(theta);
            const Eigen::Vector3d x(normal(gen), normal(gen), normal(gen));
            Eigen::Vector3d p(normal(gen), normal(gen), normal(gen));
            RealisationValues a(3), b(3);
            closed.eval(x, p, a);  // to read |L(p)|, then rescale p to the wanted theta
            const double s_now = 0.5 * (a.delta_x).squaredNorm();
            p *= theta / std::sqrt(s_now);
            closed.eval(x, p, a);
            series.eval(x, p, b);
            CHECK(relative_difference(a.alpha, b.alpha) < 1e-14);
            CHECK(relative_difference(a.delta, b.delta) < 1e-14);
            CHECK(relative_difference(a.alpha_x, b.alpha_x) < 1e-14);
            CHECK(relative_difference(a.alpha_p, b.alpha_p) < 1e-13);
            CHECK(relative_difference(a.delta_x, b.delta_x) < 1e-14);
            CHECK(relative_difference(a.delta_p, b.delta_p) < 1e-14);
        }
    }
}

TEST_CASE("realisation_eval: the closed form is offered only for skew structure matrices in dimension 3") {
    // [e1, e2] = e2, [e1, e3] = e3: a Lie algebra whose L(p) is not skew
    const auto book = structure({"x1", "x2", "x3"}, {{0, 1, "x2"}, {0, 2, "x3"}});
    CHECK(book.structure_class() == StructureClass::linear);
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(book));
    CHECK_THROWS_AS(RealisationEvaluator::rotation(book), std::invalid_argument);
    CHECK_FALSE(RealisationEvaluator::has_rotation_form(test::bundled("lotka_volterra").pi));
}
