// A run's tangent map (pgi::integrate with tangent): the product of its steps' Jacobians, computed alongside the
// steps by the one run loop's observer (scheme/trajectory.cpp), and refused where it would not be one.
#include "poisson/step_jacobian.hpp"
#include "scheme/trajectory.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

using namespace pgi;

namespace {

Eigen::VectorXd start(const Scene& s) {
    return Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
}

}  // namespace

TEST_CASE("integrate with tangent: the run's Jacobian is the product of its steps' Jacobians") {
    for (const std::string name : {"rigid_body", "henon_heiles", "lotka_volterra"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = start(s);
        const double t_end = 50 * s.dt;
        const Trajectory r = integrate(*s.scheme, x0, s.dt, t_end, 1, std::nullopt, {}, {}, {}, true);
        REQUIRE(r.status == StepStatus::ok);
        REQUIRE(r.jacobian.size() == r.dim * r.dim);
        // the same product from step_with_jacobian at each recorded state (the run's compiled step: built at x0)
        NewtonStepper st = s.scheme->stepper(s.dt, x0);
        const auto n = Eigen::Index(r.dim);
        Eigen::MatrixXd product = Eigen::MatrixXd::Identity(n, n);
        for (std::size_t k = 0; k + 1 < r.t.size(); ++k) {
            const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(r.x.data() + k * r.dim, n);
            const StepWithJacobian j = step_with_jacobian(st, x, s.dt);
            REQUIRE(j.status == StepStatus::ok);
            product = j.jacobian * product;
        }
        const Eigen::MatrixXd run =
            Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(r.jacobian.data(),
                                                                                                     n, n);
        CAPTURE((run - product).lpNorm<Eigen::Infinity>());
        CHECK((run - product).lpNorm<Eigen::Infinity>() <= 1e-13 * product.lpNorm<Eigen::Infinity>());
    }
}

TEST_CASE("integrate with tangent: refused with a terminal event, which ends the run between steps") {
    const Scene s = test::bundled("henon_heiles");
    TrajectoryEvents events;
    events.specs.push_back({"q1", 0, true});
    CHECK_THROWS_AS(integrate(*s.scheme, start(s), s.dt, 1.0, 1, std::nullopt, events, {}, {}, true), InputError);
}
