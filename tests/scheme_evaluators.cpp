// The numeric evaluators (scheme/evaluators.hpp): the vector field, pi, H, the Casimirs and the modified
// Hamiltonian at states, from maps compiled once, against hand-written formulas and runs of the method.
#include "poisson/dense_output.hpp"
#include "poisson/events.hpp"
#include "scheme/evaluators.hpp"
#include "scheme/trajectory.hpp"
#include "series/machine_code.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <random>

using namespace pgi;

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();

// m states with coordinates uniform in [-2, 2], seeded.
RowMatrix random_states(std::size_t m, std::size_t n, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    RowMatrix X(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(n));
    for (Eigen::Index j = 0; j < X.size(); ++j) X.data()[j] = u(rng);
    return X;
}

// The rigid body's pi (brackets {x1,x2} = -x3 and cyclic) and grad H for H = x1^2/4 + x2^2/2 + 3 x3^2/4, by hand.
Eigen::Matrix3d rigid_body_pi(const Eigen::Vector3d& x) {
    Eigen::Matrix3d P;
    P << 0, -x[2], x[1], x[2], 0, -x[0], -x[1], x[0], 0;
    return P;
}
Eigen::Vector3d rigid_body_grad_H(const Eigen::Vector3d& x) {
    return {x[0] / 2, x[1], 1.5 * x[2]};
}

// The cyclic Lotka-Volterra's pi ({x1,x2} = x1 x2 and cyclic) and grad H for H = x1 + x2 + x3, by hand.
Eigen::Matrix3d lotka_volterra_pi(const Eigen::Vector3d& x) {
    Eigen::Matrix3d P;
    P << 0, x[0] * x[1], -x[2] * x[0], -x[0] * x[1], 0, x[1] * x[2], x[2] * x[0], -x[1] * x[2], 0;
    return P;
}
Eigen::Vector3d lotka_volterra_grad_H(const Eigen::Vector3d&) {
    return Eigen::Vector3d::Ones();
}

using Hand = Eigen::Matrix3d (*)(const Eigen::Vector3d&);
using Grad = Eigen::Vector3d (*)(const Eigen::Vector3d&);

// The largest relative deviation of f(row) from f(row 0) over the rows of X.
double drift(const Eigen::VectorXd& f) {
    return ((f.array() - f[0]).abs() / std::abs(f[0])).maxCoeff();
}

RowMatrix run_states(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end) {
    const Trajectory tr = integrate(scheme, x0, dt, t_end, 1);
    REQUIRE(tr.status == StepStatus::ok);
    return Eigen::Map<const RowMatrix>(tr.x.data(), Eigen::Index(tr.t.size()), Eigen::Index(tr.dim));
}

}  // namespace

TEST_CASE("Evaluators: the vector field and pi equal pi grad H written by hand, on random states") {
    const std::vector<std::tuple<std::string, Hand, Grad>> cases{
        {"rigid_body", rigid_body_pi, rigid_body_grad_H}, {"lotka_volterra", lotka_volterra_pi, lotka_volterra_grad_H}};
    for (const auto& [scene, pi, grad] : cases) {
        const std::string& name = scene;  // (a name, not a binding: CAPTURE is a lambda)
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const RowMatrix X = random_states(500, 3, 34);
        const RowMatrix F = vector_field(*s.scheme, X), P = poisson_matrices(*s.scheme, X);
        for (Eigen::Index j = 0; j < X.rows(); ++j) {
            const Eigen::Vector3d x = X.row(j).transpose();
            const Eigen::Matrix3d Pj = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(P.row(j).data());
            // each entry of pi is a monomial with coefficient +-1, one product at most: the same operation, the same
            // bits
            CHECK(Pj == pi(x));
            CHECK(Pj.transpose() == -Pj);
            // each component sums 3 products of pi_ik and dH/dx_k: both sides round each product and sum (3 + 1
            // roundings at most per term, relative to the sum of the terms' magnitudes)
            const Eigen::Vector3d hand = pi(x) * grad(x), scale = pi(x).cwiseAbs() * grad(x).cwiseAbs();
            for (int i = 0; i < 3; ++i) CHECK(std::abs(F(j, i) - hand[i]) <= 4 * eps * scale[i]);
        }
    }
}

TEST_CASE("Evaluators: pi holds every bracket of the structure, and only them") {
    for (const auto& name : test::bundled_names()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const std::size_t n = s.phase_space().dim();
        const RowMatrix X = random_states(20, n, 7);
        const RowMatrix P = poisson_matrices(*s.scheme, X);
        std::vector<Poly> entries;
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t k = 0; k < n; ++k) entries.push_back(s.pi(i, k));
        // every entry compiled on its own: the brackets map forms the same monomials the same way (products of the
        // inputs)
        const CompiledMap all = CompiledMap::build(entries, s.phase_space().coordinate_vars());
        std::vector<double> expected(n * n);
        for (Eigen::Index j = 0; j < X.rows(); ++j) {
            all.eval(X.row(j).data(), expected.data());
            for (std::size_t e = 0; e < n * n; ++e)
                CHECK(P(j, Eigen::Index(e)) == doctest::Approx(expected[e]).epsilon(1e-14));
        }
    }
}

TEST_CASE("Evaluators: one row alone and among 300 rows gives the same bits") {
    const Scene s = test::bundled("henon_heiles");
    const Scheme& scheme = *s.scheme;
    const std::size_t n = s.phase_space().dim();
    const RowMatrix X = random_states(300, n, 11) / 8;  // past one block of rows (256) and its lanes' padding
    const RowMatrix F = vector_field(scheme, X), P = poisson_matrices(scheme, X), C = casimir_values(scheme, X);
    const Eigen::VectorXd H = hamiltonian_values(scheme, X), Ht = modified_hamiltonian_values(scheme, X, 0.1, 6);
    for (const Eigen::Index j : {0, 1, 7, 8, 255, 256, 299}) {
        CAPTURE(j);
        const RowMatrix x = X.row(j);
        CHECK(vector_field(scheme, x).row(0) == F.row(j));
        CHECK(poisson_matrices(scheme, x).row(0) == P.row(j));
        CHECK(casimir_values(scheme, x).row(0) == C.row(j));
        CHECK(hamiltonian_values(scheme, x)[0] == H[j]);
        CHECK(modified_hamiltonian_values(scheme, x, 0.1, 6)[0] == Ht[j]);
    }
}

TEST_CASE("Evaluators: a scheme's maps run machine code unless its jit is never, with the interpreter's bits") {
    const Scene s = test::bundled("henon_heiles");
    const Scheme& automatic = *s.scheme;
    const Scheme never(s.pi, s.H, s.casimirs, s.order, s.realisation, false, NativePolicy::never);
    const CompiledMap a = automatic.invariants({s.H * s.H}), b = never.invariants({s.H * s.H});
    const CompiledMap &fa = automatic.vector_field_map(), &fb = never.vector_field_map();
    CHECK(a.machine_code() == machine_code_supported());
    CHECK(fa.machine_code() == machine_code_supported());
    CHECK_FALSE(b.machine_code());
    CHECK_FALSE(fb.machine_code());
    const RowMatrix X = random_states(50, s.phase_space().dim(), 5);
    std::vector<double> ya(a.num_outputs()), yb(b.num_outputs()), ga(fa.num_outputs()), gb(fb.num_outputs());
    for (Eigen::Index j = 0; j < X.rows(); ++j) {
        a.eval(X.row(j).data(), ya.data());
        b.eval(X.row(j).data(), yb.data());
        CompiledMap(fa).eval(X.row(j).data(), ga.data());  // (eval on a copy: its scratch is the map's)
        CompiledMap(fb).eval(X.row(j).data(), gb.data());
        CHECK(ya == yb);
        CHECK(ga == gb);
    }
}

// A run's events and dense output are maps the scheme builds beside its step: machine code by the same policy, and
// the crossings the interpreter finds, bit for bit (a Poincare section of Henon-Heiles, both directions).
TEST_CASE("Evaluators: events and their dense output take the scheme's policy, the crossings the same bits") {
    const Scene s = test::bundled("henon_heiles");
    const Scheme never(s.pi, s.H, s.casimirs, s.order, s.realisation, false, NativePolicy::never);
    TrajectoryEvents events;
    events.specs = {{"q1", 0, false}, {"p2 - q2", 1, false}};
    events.samples = 3;
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
    const Trajectory a = integrate(*s.scheme, x0, s.dt, 40.0, 100, std::nullopt, events);
    const Trajectory b = integrate(never, x0, s.dt, 40.0, 100, std::nullopt, events);
    REQUIRE(a.status == StepStatus::ok);
    REQUIRE(a.crossings.size() >= 10);
    REQUIRE(a.crossings.size() == b.crossings.size());
    for (std::size_t i = 0; i < a.crossings.size(); ++i) {
        CAPTURE(i);
        CHECK(a.crossings[i].event == b.crossings[i].event);
        CHECK(std::bit_cast<std::uint64_t>(a.crossings[i].t) == std::bit_cast<std::uint64_t>(b.crossings[i].t));
        CHECK(a.crossings[i].x == b.crossings[i].x);
    }
    // what the runs and pgi section build them with
    for (const Scheme* scheme : {s.scheme.get(), &never}) {
        EventSet set = scheme->event_set(events.specs, {});
        DenseOutput dense = scheme->dense_output(4);
        std::vector<CompiledMap*> maps = set.compiled_maps();
        maps.push_back(dense.compiled_maps()[0]);
        const bool machine = scheme->jit() != NativePolicy::never && machine_code_supported();
        for (const CompiledMap* m : maps) CHECK(m->machine_code() == machine);
    }
}

TEST_CASE("Evaluators: the Casimirs stay at round-off along a run") {
    for (const auto& name : {"rigid_body", "lotka_volterra"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const RowMatrix X = run_states(*s.scheme, Eigen::Map<const Eigen::VectorXd>(s.x0->data(), 3), 0.1, 20.0);
        const RowMatrix C = casimir_values(*s.scheme, X);
        REQUIRE(C.cols() == 1);
        // 200 steps, each solved to round-off (a few ulps of |x|^2 or x1 x2 x3 per step): 200 * 4 eps < 2e-13, while
        // H, which the method does not conserve, drifts by 1e-8 or more here (an evaluator reading H would fail)
        CHECK(drift(C.col(0)) < 2e-13);
        CHECK(drift(hamiltonian_values(*s.scheme, X)) > 1e-9);
    }
}

TEST_CASE("Evaluators: the modified Hamiltonian is conserved better than H by the order's factor") {
    SchemeValues v;
    v.coordinates = {"x1", "x2", "x3"};
    v.brackets = {{"x1,x2", "-x3"}, {"x2,x3", "-x1"}, {"x3,x1", "-x2"}};
    v.hamiltonian = "x1^2/4 + x2^2/2 + 3*x3^2/4";
    for (const long k : {2, 4}) {
        CAPTURE(k);
        v.order = k;
        const Scheme scheme = Scheme::from_values(v);
        const std::size_t p = scheme.method_order(), upto = p;
        Eigen::VectorXd x0(3);
        x0 << 0.6, 0.8, 0.3;
        double dH[2], dHt[2];
        for (int h = 0; h < 2; ++h) {
            const double dt = 0.2 / (1 << h);
            const RowMatrix X = run_states(scheme, x0, dt, 10.0);
            dH[h] = drift(hamiltonian_values(scheme, X));
            dHt[h] = drift(modified_hamiltonian_values(scheme, X, dt, upto));
        }
        // H drifts like dt^p: halving dt divides it by 2^p (measured 4.00 and 16.0); H~ through dt^upto like
        // dt^(upto+1) at most (measured dt^(upto+2): the method is symmetric, H_(upto+1) = 0), so the gain of H~
        // over H grows by 2^(upto+1-p) or more per halving. 20% for the constants of the next order.
        CHECK(dH[0] / dH[1] == doctest::Approx(std::pow(2.0, double(p))).epsilon(0.2));
        CHECK(dHt[0] / dHt[1] > 0.8 * std::pow(2.0, double(upto + 1)));
        CHECK(dHt[0] < dH[0] / 100);  // measured 500x (k = 2) and 300x (k = 4) at dt = 0.2
    }
}

TEST_CASE("Evaluators: each map is compiled once, the exact phase run once") {
    const Scene s = test::bundled("rigid_body");
    const Scheme scheme = *s.scheme;  // a copy starts empty
    const RowMatrix X = random_states(10, 3, 3);
    for (int i = 0; i < 3; ++i) {
        vector_field(scheme, X);
        poisson_matrices(scheme, X);
        hamiltonian_values(scheme, X);
        casimir_values(scheme, X);  // the same map as H's
        modified_hamiltonian_values(scheme, X, 0.1, 4);
        modified_hamiltonian_values(scheme, X, 0.05, 4);  // dt is an input of the sum, not of the map
    }
    const SchemeStats st = scheme.stats();
    CHECK(st.evaluator_builds == 4);
    CHECK(st.modified_builds == 1);
    CHECK(st.terms_builds == 1);
    modified_hamiltonian_values(scheme, X, 0.1, 2);  // a smaller upto: its own map, H_0..H_2 kept from upto 4
    CHECK(scheme.stats().evaluator_builds == 5);
    CHECK(scheme.stats().modified_builds == 1);
}

TEST_CASE("Evaluators: bad states, dt and upto are refused by name before any work") {
    const Scene s = test::bundled("rigid_body");
    const Scheme scheme = *s.scheme;
    RowMatrix X = RowMatrix::Ones(4, 3);
    CHECK_THROWS_WITH_AS(vector_field(scheme, RowMatrix::Ones(4, 2)),
                         "x: must have 3 columns (one per coordinate), got 2", InputError);
    X(2, 1) = std::nan("");
    CHECK_THROWS_WITH_AS(hamiltonian_values(scheme, X), "x: row 2 is not finite", InputError);
    X(2, 1) = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH_AS(modified_hamiltonian_values(scheme, X, 0.1, 2), "x: row 2 is not finite", InputError);
    X(2, 1) = 1;
    CHECK_THROWS_WITH_AS(modified_hamiltonian_values(scheme, X, 0.0, 2), "dt: must be positive and finite", InputError);
    CHECK_THROWS_WITH_AS(modified_hamiltonian_values(scheme, X, 0.1, 65), "upto: must be at most 64", InputError);
    CHECK(scheme.stats().terms_builds == 0);
    CHECK(vector_field(scheme, RowMatrix(0, 3)).rows() == 0);
}
