// The public header's boundary: pgi.hpp gives the whole library without the step's lane kernels (GCC vector
// extensions and their diagnostics pragma, internal to the step and the ensembles), and a program that includes only
// pgi.hpp can still build, copy and run a step that uses them.
#include "pgi.hpp"

#ifdef PGI_LANE_KERNELS_INCLUDED
#error "pgi.hpp includes poisson/lanes.hpp: the lane kernels must stay behind NewtonStepper's LaneSteps"
#endif

#include "test_util.hpp"

#include <doctest/doctest.h>

TEST_CASE("Public header: a step with a lane form is built, copied and run through pgi.hpp alone") {
    const pgi::Scene s = pgi::test::bundled("rigid_body");
    Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
    pgi::NewtonStepper built = s.scheme->stepper(0.1, x);
    REQUIRE(built.lane_dimension() == 3);  // the so(3) closed form steps on lanes
    pgi::NewtonStepper copy = built;       // a deep copy: stepping it leaves the original as it was
    Eigen::VectorXd a(3), b(3), c(3);
    REQUIRE(copy.step(x, a) == pgi::StepStatus::ok);
    REQUIRE(copy.step(x + a, b) == pgi::StepStatus::ok);
    pgi::NewtonStepper moved = std::move(copy);
    REQUIRE(built.step(x, c) == pgi::StepStatus::ok);
    CHECK(c == a);  // the original's first step is the copy's, bit for bit
    built = moved;  // copy-assigned over an existing lane step
    REQUIRE(built.step(x, c) == pgi::StepStatus::ok);
    CHECK(c == a);
    CHECK(built.lane_dimension() == 3);
}
