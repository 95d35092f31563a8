// The batch step: every lane's increment, status and Newton statistics are the single step's bit for bit,
// whatever the number of lanes and states, at the build's dt (its exact planned sum) and at others (the
// Horner path), with failing and non-finite states in the batch.
#include "poisson/batch_step.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>

using namespace pgi;

namespace {

// m states around x0: scaled by 0.5..1.5 and turned (coordinates rotated by i), deterministic
std::vector<Eigen::VectorXd> states_around(const Eigen::VectorXd& x0, std::size_t m) {
    std::vector<Eigen::VectorXd> X;
    for (std::size_t i = 0; i < m; ++i) {
        Eigen::VectorXd x = x0;
        for (Eigen::Index v = 0; v < x.size(); ++v)
            x[v] = x0[(v + Eigen::Index(i)) % x.size()] * (0.5 + double(i) / double(m));
        X.push_back(x);
    }
    return X;
}

// The lane forms' instruction sets this processor runs: SSE2 always, AVX2 where it has it.
std::vector<LaneInstructions> instruction_sets() {
    std::vector<LaneInstructions> sets{LaneInstructions::sse2};
    if (processor_has_avx2()) sets.push_back(LaneInstructions::avx2);
    return sets;
}

// Steps the states with the batch and one by one with a copy of stepper; every number must be equal.
void require_lanes_equal_single(const NewtonStepper& stepper, std::size_t lanes,
                                const std::vector<Eigen::VectorXd>& states, double dt, LaneInstructions instructions) {
    const std::size_t n = stepper.dim(), m = states.size();
    BatchStepper batch(stepper, lanes, instructions);
    // the dense steps at N = 2, 3, 4, 6 with a closed so(3) or compiled polynomial realisation run on lanes
    CHECK((batch.instructions() == LaneInstructions::automatic) == (stepper.lane_dimension() == 0));
    if (stepper.lane_dimension() != 0) CHECK(batch.instructions() == instructions);
    std::vector<double> X(n * m), increments(n * m);
    for (std::size_t j = 0; j < m; ++j)
        for (std::size_t v = 0; v < n; ++v) X[v * m + j] = states[j][Eigen::Index(v)];
    std::vector<StepStatus> status(m);
    batch.step(X.data(), m, dt, increments.data(), status.data());
    NewtonStepper single = stepper;
    Eigen::VectorXd increment = Eigen::VectorXd::Zero(Eigen::Index(n));
    for (std::size_t j = 0; j < m; ++j) {
        CAPTURE(j);
        const StepStatus s = single.step(states[j], dt, increment);
        CHECK(status[j] == s);
        CHECK(batch.last_iterations(j) == single.last_iterations());
        CHECK(batch.last_residual(j) == single.last_residual());
        if (s != StepStatus::ok) continue;
        for (std::size_t v = 0; v < n; ++v) CHECK(increments[v * m + j] == increment[Eigen::Index(v)]);
    }
}

}  // namespace

TEST_CASE(
    "BatchStepper: each lane is the single step bit for bit, on every bundled scene, at the build's dt and at others") {
    for (const std::string& name : test::bundled_names()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        if (!s.x0) continue;  // (a scene for pgi magnus only)
        const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
        const double dt = s.dt;
        const NewtonStepper stepper = s.scheme->stepper(dt, x0);
        for (const double h : {dt, dt / 2, 0.7 * dt}) {
            CAPTURE(h);
            for (const std::size_t m : {1, 5, 8, 13})
                for (const LaneInstructions instructions : instruction_sets()) {
                    CAPTURE(m);
                    CAPTURE(int(instructions));
                    require_lanes_equal_single(stepper, 16, states_around(x0, m), h, instructions);
                }
        }
    }
}

TEST_CASE(
    "BatchStepper: which steps run on lanes; a step without a lane form (sl(2)*) goes state by state, the same bits") {
    for (const auto& name : {"rigid_body", "lotka_volterra", "henon_heiles", "volterra_chain", "nambu"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
        CHECK(s.scheme->stepper(s.dt, x0).lane_dimension() == x0.size());
    }
    // sl(2)*: linear, not skew, so the Lie-Poisson series (no lane form yet)
    SchemeValues v;
    v.coordinates = {"h", "e", "f"};
    v.brackets = {{"h,e", "2*e"}, {"h,f", "-2*f"}, {"e,f", "h"}};
    v.hamiltonian = "h^2/2 + e*f/3";
    v.order = 4;
    const Scheme sl2 = Scheme::from_values(v);
    const Eigen::Vector3d x0(0.5, 0.3, -0.2);
    const NewtonStepper stepper = sl2.stepper(0.05, x0);
    CHECK(stepper.lane_dimension() == 0);
    for (const std::size_t m : {1, 5, 13}) {
        CAPTURE(m);
        require_lanes_equal_single(stepper, 16, states_around(x0, m), 0.05, LaneInstructions::automatic);
    }
    if (!processor_has_avx2()) {
        const Scene s = test::bundled("rigid_body");
        const NewtonStepper rigid = s.scheme->stepper(0.1, Eigen::Vector3d(1, 0, 0));
        CHECK_THROWS_AS(BatchStepper(rigid, 8, LaneInstructions::avx2), std::invalid_argument);
    }
}

TEST_CASE("BatchStepper: the rigid body with parameters steps on lanes (N = 3, so(3) closed form), bit for bit") {
    // the parameters are the last three coordinates, with zero rows: the closed form leaves them alone, and Newton
    // solves for the three others (the parameters are inputs of the maps)
    const Scene s = test::bundled("rigid_body_parameters");
    Eigen::VectorXd x0(6);
    x0 << Eigen::Map<const Eigen::Vector3d>(s.x0->data()), 0.5, 1.0, 1.5;
    const NewtonStepper stepper = s.scheme->stepper(s.dt, x0);
    CHECK(stepper.lane_dimension() == 3);
    CHECK(stepper.info().method.find("so(3)") != std::string::npos);
    for (const double h : {s.dt, 0.7 * s.dt})
        for (const std::size_t m : {1, 5, 13})
            for (const LaneInstructions instructions : instruction_sets()) {
                CAPTURE(h);
                CAPTURE(m);
                require_lanes_equal_single(stepper, 16, states_around(x0, m), h, instructions);
            }
    // each state's parameters stay bit for bit: their increments are exactly zero
    NewtonStepper single = stepper;
    Eigen::VectorXd increment(6);
    for (const Eigen::VectorXd& x : states_around(x0, 13)) {
        REQUIRE(single.step(x, s.dt, increment) == StepStatus::ok);
        CHECK(increment.tail(3).isZero(0));
        CHECK(increment.head(3).lpNorm<Eigen::Infinity>() > 0);
    }
}

// c q^6 + (q^2 + P^2) / 2 at c = 0 is an oscillator, which steps at amplitude 1e60; its grad and Hess S_dt still hold
// c^j q^(4 j + 2)-like monomials, infinite there, whose coefficients vanish at c = 0. The single step's maps mask such
// a coefficient (0 inf is NaN); each lane must too, on either instruction set, beside lanes whose c does not vanish.
TEST_CASE(
    "BatchStepper: a coefficient that vanishes at a lane's parameter masks an overflowing monomial, as one step") {
    SchemeValues v;
    v.coordinates = {"q", "P"};
    v.brackets = {{"q,P", "1"}};
    v.hamiltonian = "c*q^6 + q^2/2 + P^2/2";
    v.order = 4;
    v.parameters = {{"c", "1"}};
    const Scheme scheme(v);
    const NewtonStepper stepper = scheme.stepper(0.1, Eigen::Vector3d(0.6e60, 0.8e60, 0.25));
    REQUIRE(stepper.lane_dimension() == 2);
    std::vector<Eigen::VectorXd> states;
    for (std::size_t j = 0; j < 16; ++j) {
        const double amplitude = j % 2 ? 1e60 : 0.7;
        states.push_back(Eigen::Vector3d(0.6 * amplitude, 0.8 * amplitude, j % 4 < 2 ? 0.0 : 0.25));
    }
    for (const LaneInstructions instructions : instruction_sets())
        require_lanes_equal_single(stepper, 16, states, 0.1, instructions);
    // the states at 1e60 with c = 0 step (finite), those with c = 0.25 do not
    NewtonStepper single = stepper;
    Eigen::VectorXd increment(3);
    CHECK(single.step(states[1], 0.1, increment) == StepStatus::ok);
    CHECK(increment.head(2).allFinite());
    CHECK(single.step(states[3], 0.1, increment) != StepStatus::ok);
}

TEST_CASE("BatchStepper: a failing and a non-finite state fail alone, with the single step's status") {
    const Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), 3);
    const NewtonStepper stepper = s.scheme->stepper(0.1, x0);
    auto states = states_around(x0, 9);
    states[2] *= 1e4;  // dt |x| ~ 1e3: far beyond what the step built at x0 solves
    states[6][1] = std::numeric_limits<double>::quiet_NaN();
    for (const LaneInstructions instructions : instruction_sets())
        require_lanes_equal_single(stepper, 9, states, 0.1, instructions);
    BatchStepper batch(stepper, 9);
    std::vector<double> X(27), increments(27);
    for (std::size_t j = 0; j < 9; ++j)
        for (std::size_t v = 0; v < 3; ++v) X[v * 9 + j] = states[j][Eigen::Index(v)];
    std::vector<StepStatus> status(9);
    batch.step(X.data(), 9, 0.1, increments.data(), status.data());
    CHECK(status[2] != StepStatus::ok);
    CHECK(status[6] == StepStatus::non_finite);
    for (std::size_t j : {0, 1, 3, 4, 5, 7, 8}) CHECK(status[j] == StepStatus::ok);
    CHECK_THROWS_AS(batch.step(X.data(), 10, 0.1, increments.data(), status.data()),
                    std::invalid_argument);  // more states than lanes
}

TEST_CASE("BatchStepper: the AVX2 kernels' file sees the library's types with the same layout as the rest of it") {
    // it is compiled with -mavx2, under which Eigen would align its fixed-size types to 32 bytes, not 16
    const LaneLayout baseline = baseline_lane_layout, avx2 = avx2_lane_layout;
    for (std::size_t i = 0; i < 8; ++i) {
        CAPTURE(i);
        CHECK(baseline.values[i] == avx2.values[i]);
    }
    CHECK(baseline.values[0] > 0);
}
