// The sparse Newton path (poisson/detail/newton_matrix, sparse_hessian, sparse_pattern, realisation_eval_sparse): the
// same steps as the dense path to the step's own round-off tolerance, on banded and non-banded patterns, for the
// closed and the compiled polynomial realisation; honest failures; the patterns stay local.
#include "poisson/detail/newton_matrix.hpp"
#include "poisson/newton_step.hpp"
#include "poisson/detail/sparse_hessian.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <random>

using namespace pgi;

namespace {

// A log-canonical structure {x_i, x_j} = x_i x_j on the given pairs (any constant skew a_ij satisfies Jacobi),
// with H = sum x_i.
struct LogCanonical {
    PoissonStructure pi;
    Poly H;
};

LogCanonical log_canonical(std::size_t n, const std::vector<std::pair<int, int>>& pairs) {
    std::vector<std::string> names;
    for (std::size_t i = 1; i <= n; ++i) names.push_back("x" + std::to_string(i));
    std::vector<std::tuple<int, int, std::string>> brackets;
    for (const auto& [i, j] : pairs) brackets.emplace_back(i, j, names[std::size_t(i)] + "*" + names[std::size_t(j)]);
    PoissonStructure pi = test::structure(names, brackets);
    Poly H(pi.phase_space().ring());
    for (std::size_t i = 0; i < n; ++i) H += pi.phase_space().x_gen(i);
    return {std::move(pi), std::move(H)};
}

// The periodic Volterra lattice {x_i, x_i+1} = x_i x_i+1.
LogCanonical lattice(std::size_t n) {
    std::vector<std::pair<int, int>> pairs;
    for (std::size_t i = 0; i < n; ++i) pairs.emplace_back(int(i), int((i + 1) % n));
    return log_canonical(n, pairs);
}

Eigen::VectorXd smooth_state(std::size_t n) {
    Eigen::VectorXd x(static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i)
        x[Eigen::Index(i)] = 1.0 + 0.5 * std::sin(2 * M_PI * double(i) / double(n)) + 0.1 * std::cos(3.0 * double(i));
    return x;
}

NewtonStepper build(const LogCanonical& s, NewtonSolverChoice solver, std::size_t k, double dt,
                    const Eigen::VectorXd& x0, RealisationChoice realisation = RealisationChoice::automatic) {
    StepOptions opt;
    opt.k = k;
    opt.dt = dt;
    opt.solver = solver;
    opt.realisation = realisation;
    return NewtonStepper::build(s.pi, s.H, opt, x0);
}

// Both paths from the same states along a run: each step is accepted where |alpha(xb, grad S_dt(xb)) - x_i| <= tol_i,
// tol = 64 u (|x| + sizes) (last_tolerance() is its largest entry), so the two base points solve the same equation to
// within tol each and differ by at most |J^-1| (tol_dense + tol_sparse); J = I + O(dt) here (|J^-1|_inf < 2), and the
// increments delta(xb) move with xb by |d delta/d xb| = O(dt). Hence |increment_dense - increment_sparse| <= 4 max tol
// (with room); a wrong assembly or pattern is off by O(dt) = 1e-2.
void same_steps(const LogCanonical& s, std::size_t k, double dt, RealisationChoice realisation, int steps) {
    const std::size_t n = s.pi.dim();
    const Eigen::VectorXd x0 = smooth_state(n);
    NewtonStepper dense = build(s, NewtonSolverChoice::dense, k, dt, x0, realisation);
    NewtonStepper sparse = build(s, NewtonSolverChoice::sparse, k, dt, x0, realisation);
    REQUIRE(dense.info().solver == NewtonSolver::dense);
    REQUIRE(sparse.info().solver == NewtonSolver::sparse);
    CHECK(dense.info().predictor_order == sparse.info().predictor_order);
    Eigen::VectorXd x = x0, a(x.size()), b(x.size());
    double worst = 0;
    for (int m = 0; m < steps; ++m) {
        REQUIRE(dense.step(x, a) == StepStatus::ok);
        REQUIRE(sparse.step(x, b) == StepStatus::ok);
        const double tol = std::max(dense.last_tolerance(), sparse.last_tolerance());
        CHECK((a - b).lpNorm<Eigen::Infinity>() <= 4 * tol);
        CHECK(sparse.residual_at_solution(x) <= sparse.last_tolerance());
        worst = std::max(worst, (a - b).lpNorm<Eigen::Infinity>());
        x += a;
    }
    MESSAGE("largest difference of the increments: " << worst);
    // and the Jacobian the sparse path assembles is the dense one's (same blocks; sums in another order)
    const Eigen::MatrixXd Jd = dense.newton_system(x), Js = sparse.newton_system(x);
    CHECK((Jd - Js).lpNorm<Eigen::Infinity>() <= 1e-14 * Jd.lpNorm<Eigen::Infinity>());
}

}  // namespace

TEST_CASE("sparse step: the periodic Volterra lattice (n = 12, k = 4, dt = 1/20) steps as the dense path does") {
    same_steps(lattice(12), 4, 0.05, RealisationChoice::automatic, 50);
}

TEST_CASE("sparse step: a non-banded sparse structure (long-range pairs) steps as the dense path does") {
    // pairs (i, i + 1) and (i, 7 i + 3 mod n): no bandwidth below ~n/2 in any natural order
    const std::size_t n = 40;
    std::vector<std::pair<int, int>> pairs;
    for (std::size_t i = 0; i < n; ++i) {
        pairs.emplace_back(int(i), int((i + 1) % n));
        const std::size_t j = (7 * i + 3) % n;
        if (j != i && j != (i + 1) % n && (j + 1) % n != i)
            pairs.emplace_back(int(std::min(i, j)), int(std::max(i, j)));
    }
    const LogCanonical s = log_canonical(n, pairs);
    same_steps(s, 2, 0.05, RealisationChoice::automatic, 20);
}

TEST_CASE(
    "sparse step: the compiled polynomial (radial) realisation on its derivative pattern steps as the dense path "
    "does") {
    same_steps(lattice(8), 2, 0.05, RealisationChoice::radial, 20);
}

TEST_CASE("sparse step: the patterns are local: the lattice's Hessian and Newton matrix hold O(n) entries") {
    for (std::size_t n : {40, 80}) {
        const LogCanonical s = lattice(n);
        NewtonStepper st = build(s, NewtonSolverChoice::automatic, 4, 0.05, smooth_state(n));
        CHECK(st.info().solver == NewtonSolver::sparse);  // n >= NewtonMatrix::sparse_from_dimension, sparse pattern
        // J couples each site to its neighbours up to distance 4 (alpha_p: 1, Hess S_dt of k = 4: 3): 9 a column
        const Eigen::MatrixXd J = st.newton_system(smooth_state(n));
        Eigen::Index nonzeros = (J.array() != 0).count();
        CHECK(nonzeros <= Eigen::Index(9 * n));
        CHECK(nonzeros >= Eigen::Index(3 * n));
    }
}

TEST_CASE("sparse step: the Casimirs of the lattice are kept to round-off, and bad input still fails honestly") {
    const std::size_t n = 40;  // even: x1 x3 ... x39 and x2 x4 ... x40 are Casimirs
    const LogCanonical s = lattice(n);
    const Eigen::VectorXd x0 = smooth_state(n);
    NewtonStepper st = build(s, NewtonSolverChoice::sparse, 4, 0.05, x0);
    auto log_casimirs = [&](const Eigen::VectorXd& x) {
        double odd = 0, even = 0;
        for (std::size_t i = 0; i < n; ++i) (i % 2 ? even : odd) += std::log(x[Eigen::Index(i)]);
        return std::make_pair(odd, even);
    };
    Eigen::VectorXd x = x0, inc(x.size());
    for (int m = 0; m < 400; ++m) {
        REQUIRE(st.step(x, inc) == StepStatus::ok);
        x += inc;
    }
    // log C = sum of n/2 logs, each rounded and moved by ~u per step: 400 steps stay far below 1e-11
    CHECK(std::abs(log_casimirs(x).first - log_casimirs(x0).first) < 1e-11);
    CHECK(std::abs(log_casimirs(x).second - log_casimirs(x0).second) < 1e-11);
    // a non-finite state is refused, not stepped
    Eigen::VectorXd bad = x0;
    bad[7] = std::nan("");
    CHECK(st.step(bad, inc) == StepStatus::non_finite);
    // a step far too large for the lattice (dt = 40, u_j ~ dt x ~ 40 in the exponentials): refused, not returned
    NewtonStepper huge = build(s, NewtonSolverChoice::sparse, 4, 40.0, x0);
    const StepStatus status = huge.step(x0, inc);
    MESSAGE("dt = 40: " << to_string(status) << ", residual " << huge.last_residual() << ", tolerance "
                        << huge.last_tolerance());
    CHECK(status != StepStatus::ok);
}

TEST_CASE("newton matrix: the sparse and dense solves agree on random sparse systems; a singular one is refused") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U(-1, 1);
    const std::size_t n = 60;
    // alpha_x: the identity and a random sparse part; alpha_p and the Hessian: random sparse
    auto random_pattern = [&](double fill, bool diagonal) {
        std::vector<std::vector<int>> cols(n);
        for (std::size_t c = 0; c < n; ++c) {
            if (diagonal) cols[c].push_back(int(c));
            for (std::size_t r = 0; r < n; ++r)
                if (std::abs(U(rng)) < fill) cols[c].push_back(int(r));
        }
        return SparsePattern::from_columns(n, cols);
    };
    const SparsePattern ax = random_pattern(0.03, true), ap = random_pattern(0.03, false),
                        h = random_pattern(0.03, false);
    std::vector<double> vx(ax.nonzeros()), vp(ap.nonzeros()), vh(h.nonzeros());
    for (std::size_t c = 0; c < n; ++c)
        for (int k = ax.outer[c]; k < ax.outer[c + 1]; ++k)
            vx[std::size_t(k)] = ax.inner[std::size_t(k)] == int(c) ? 4.0 : U(rng);
    for (auto& v : vp) v = 0.3 * U(rng);
    for (auto& v : vh) v = 0.3 * U(rng);
    NewtonMatrix dense(ax, ap, h, NewtonSolverChoice::dense), sparse(ax, ap, h, NewtonSolverChoice::sparse);
    CHECK(NewtonMatrix(ax, ap, h, NewtonSolverChoice::automatic).solver() == NewtonSolver::sparse);
    dense.assemble(vx.data(), vp.data(), vh.data());
    sparse.assemble(vx.data(), vp.data(), vh.data());
    // J from the dense blocks, independently of the patterns' bookkeeping
    Eigen::MatrixXd AX, AP, H;
    ax.scatter(vx.data(), AX), ap.scatter(vp.data(), AP), h.scatter(vh.data(), H);
    const Eigen::MatrixXd J = AX + AP * H;
    CHECK((sparse.dense() - J).lpNorm<Eigen::Infinity>() <= 1e-15 * J.lpNorm<Eigen::Infinity>() * double(n));
    Eigen::VectorXd r(static_cast<Eigen::Index>(n)), a, b;
    for (Eigen::Index i = 0; i < r.size(); ++i) r[i] = U(rng);
    REQUIRE(dense.solve(r, a));
    NewtonMatrix copy = sparse;  // a copy analyses the pattern anew and solves the same
    REQUIRE(sparse.solve(r, b));
    // both are backward stable: |J dx - r| ~ n u |J| |dx|; diagonally dominant J (|J^-1| < 1), so the solutions
    // differ by a few n u
    CHECK((J * b - r).lpNorm<Eigen::Infinity>() <= 1e-13);
    CHECK((a - b).lpNorm<Eigen::Infinity>() <= 1e-13);
    copy.assemble(vx.data(), vp.data(), vh.data());
    Eigen::VectorXd c;
    REQUIRE(copy.solve(r, c));
    CHECK(c == b);
    // a zero matrix: SparseLU reports the failure, the step turns it into a failed step
    std::vector<double> zx(vx.size(), 0.0), zp(vp.size(), 0.0), zh(vh.size(), 0.0);
    sparse.assemble(zx.data(), zp.data(), zh.data());
    CHECK_FALSE(sparse.solve(r, b));
}

TEST_CASE("sparse hessian: grad S_dt and Hess S_dt on its whole pattern from the upper triangle compiled, exactly") {
    // random S_1..S_3 in four coordinates with dyadic coefficients, a dyadic dt and point: every term and partial sum
    // is exact in double, so the compiled values equal the exact ones whatever the evaluation order
    PhaseSpace M({"a", "b", "c", "d"});
    std::mt19937 gen(13);
    std::uniform_int_distribution<long> coeff(-7, 7);
    std::uniform_int_distribution<unsigned long> ex(0, 2);
    std::vector<Poly> S;
    for (int j = 0; j < 3; ++j) {
        Poly f(M.ring());
        for (int t = 0; t < 12; ++t) {
            Poly m = Poly::constant(M.ring(), Rational(coeff(gen), 4));
            for (std::size_t v = 0; v < 3; ++v) m = m * pow(M.x_gen(v), ex(gen));  // d never appears: a row of zeros
            f += m;
        }
        S.push_back(f);
    }
    const double dt = 0.5;
    const CompiledGradient g = compile_gradient(M, S, dt);
    const Poly S_dt = sum_powers(S, Rational::from_double(dt), 1);
    std::vector<double> point(M.ring()->size(), 0.0), x{0.5, -2, 1, 4};
    std::copy(x.begin(), x.end(), point.begin());
    std::vector<double> gh(g.with_hessian.width()), hessian(g.hessian.nonzeros());
    g.with_hessian.eval(x.data(), dt, gh.data());
    expand_hessian(g, gh.data() + 4, hessian.data());
    std::size_t upper = 0, mirrored = 0;
    for (std::size_t c = 0; c < 4; ++c) {
        const Poly dc = derivative(S_dt, M.x(c));
        CHECK(gh[c] == evaluate(dc, point));
        for (int k = g.hessian.outer[c]; k < g.hessian.outer[c + 1]; ++k) {
            const auto r = std::size_t(g.hessian.inner[std::size_t(k)]);
            CAPTURE(r);
            CAPTURE(c);
            CHECK(hessian[std::size_t(k)] == evaluate(derivative(dc, M.x(r)), point));
            CHECK(g.hessian.find(int(c), int(r)) >= 0);  // symmetric pattern
            (r <= c ? upper : mirrored)++;
        }
    }
    CHECK(mirrored > 0);
    CHECK(g.with_hessian.width() == 4 + upper);       // only the upper triangle compiled
    CHECK(g.hessian.outer[4] == g.hessian.outer[3]);  // d holds nothing
}

TEST_CASE("sparse hessian: a passive coordinate's gradient and Hessian entries are left out of the Newton maps only") {
    // S_1, S_2 in (a, b, w), w passive (its row of pi zero, as a parameter's): dyadic values, so exact in double
    PhaseSpace M({"a", "b", "w"});
    const std::vector<Poly> S{M.parse("a^2*w + b*w^2 + a*b"), M.parse("a*b*w + 3*w^3 + b^2")};
    const double dt = 0.5;
    const CompiledGradient g = compile_gradient(M, S, dt, {}, {false, false, true});
    const Poly S_dt = sum_powers(S, Rational::from_double(dt), 1);
    const std::vector<double> x{0.5, -1, 1.5};
    std::vector<double> point(M.ring()->size(), 0.0);
    std::copy(x.begin(), x.end(), point.begin());
    std::vector<double> gh(g.with_hessian.width()), grad(3), upper(g.with_hessian.width() - 3);
    g.with_hessian.eval(x.data(), dt, gh.data());
    g.gradient.eval(x.data(), dt, grad.data());
    REQUIRE_FALSE(g.full_hessian.empty());
    g.full_hessian.eval(x.data(), dt, upper.data());
    std::vector<double> newton(g.hessian.nonzeros()), whole(g.hessian.nonzeros());
    expand_hessian(g, gh.data() + 3, newton.data());
    expand_hessian(g, upper.data(), whole.data());
    for (std::size_t c = 0; c < 3; ++c) {
        const Poly dc = derivative(S_dt, M.x(c));
        CHECK(gh[c] == (c == 2 ? 0.0 : evaluate(dc, point)));
        CHECK(grad[c] == gh[c]);
        for (int k = g.hessian.outer[c]; k < g.hessian.outer[c + 1]; ++k) {
            const auto r = std::size_t(g.hessian.inner[std::size_t(k)]);
            CAPTURE(r);
            CAPTURE(c);
            const double exact = evaluate(derivative(dc, M.x(r)), point);
            CHECK(exact != 0);
            CHECK(whole[std::size_t(k)] == exact);
            CHECK(newton[std::size_t(k)] == (r == 2 || c == 2 ? 0.0 : exact));
        }
    }
    CHECK(g.hessian.find(2, 2) >= 0);  // the pattern keeps every entry: only the values are left out
}
