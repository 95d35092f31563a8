// Modified Hamiltonians of the Hamilton-Jacobi schemes (docs/math.md 7): exact answers, structure, and the
// backward error property, exactly as series and numerically.
#include "magnus/magnus.hpp"
#include "magnus/modified_hamiltonian.hpp"
#include "poisson/detail/bisection.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "series/composition.hpp"
#include "poisson/integrate.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace pgi;

namespace {

// The step of size t as exact t-series: phi_t = Phi^beta_t o (Phi^alpha_t)^{-1} (docs/math.md 6).
std::vector<Series> step_series(const Scene& s, std::size_t k, std::size_t N) {
    const PhaseSpace& M = s.phase_space();
    Realisation r = build_realisation(s.pi, s.realisation, std::max(N, k));
    auto S = hamilton_jacobi_terms(M, r, s.H, k);
    auto v = inverse_near_identity(bisection_displacement(M, r, Side::alpha, S, N), M.coordinate_vars(), N);
    std::vector<std::optional<Series>> images(M.ring()->size());
    for (std::size_t i = 0; i < M.dim(); ++i) images[M.x(i)] = Series::constant(M.x_gen(i), N) + v[i];
    auto phi = compose(bisection_displacement(M, r, Side::beta, S, N), images, N);
    for (std::size_t i = 0; i < M.dim(); ++i) phi[i] += Series::constant(M.x_gen(i), N) + v[i];
    return phi;
}

// The time-t flow of the Hamiltonian K_t (a t-series, t also the step), by its Lie series sum_n t^n/n! L^n x.
std::vector<Series> flow_series(const PoissonStructure& pi, const Series& K, std::size_t N) {
    const PhaseSpace& M = pi.phase_space();
    std::vector<Series> out;
    for (std::size_t i = 0; i < M.dim(); ++i) {
        Series term = Series::constant(M.x_gen(i), N), sum = term;
        for (std::size_t n = 1; n < N; ++n) {
            // t^n/n! L^n x: one more bracket with K, one more power of t
            Series next = poisson_bracket(pi, term, K);
            Series shifted(M.ring(), N);
            for (std::size_t m = 0; m + 1 < N; ++m)
                shifted[m + 1] = Rational(1, static_cast<unsigned long>(n)) * next[m];
            term = shifted;
            sum += term;
        }
        out.push_back(sum);
    }
    return out;
}

Series as_series(const std::vector<Poly>& terms, std::size_t N) {
    Series s(terms.front().ring(), N);
    for (std::size_t j = 0; j < std::min(N, terms.size()); ++j) s[j] = terms[j];
    return s;
}

}  // namespace

TEST_CASE(
    "modified: the oscillator's midpoint rule has Htilde = (2/dt) arctan(dt/2) H = H (1 - dt^2/12 + dt^4/80 - "
    "dt^6/448)") {
    Scene s = test::bundled("harmonic_oscillator");
    auto Ht = modified_hamiltonian(s.pi, s.H, 1, RealisationChoice::automatic, 6);
    REQUIRE(Ht.size() == 7);
    CHECK(Ht[0] == s.H);
    CHECK(Ht[2] == Rational(-1, 12) * s.H);
    CHECK(Ht[4] == Rational(1, 80) * s.H);
    CHECK(Ht[6] == Rational(-1, 448) * s.H);
    for (std::size_t j : {1, 3, 5}) CHECK(Ht[j].is_zero());
}

namespace {

// pi grad H_j from the step alone, by Lie-series matching: the time-t flow of sum_{i<j} t^i H_i agrees with the
// step through t^j, and at t^(j+1) they differ by exactly t^(j+1) pi grad H_j (the flow's first term in H_j).
std::vector<Poly> matched_field(const Scene& s, const std::vector<Series>& step, const std::vector<Poly>& lower,
                                std::size_t j) {
    const std::size_t N = j + 2;
    Series K(s.phase_space().ring(), N);
    for (std::size_t i = 0; i < j; ++i) K[i] = lower[i];
    const auto flow = flow_series(s.pi, K, N);
    std::vector<Poly> field;
    for (std::size_t i = 0; i < step.size(); ++i) field.push_back(step[i][j + 1] - flow[i][j + 1]);
    return field;
}

}  // namespace

// issue 16.3
TEST_CASE("H_j = 0 below the order, odd H_j = 0, and pi grad H_j equals the Lie-series matching of the step") {
    // The step's exact t-series (inverse of the source map, then the target map: no Magnus series and no
    // variation functions) fixes pi grad H_j order by order; H_j itself is fixed only modulo Casimirs, so the
    // fields are compared, exactly. The old check {H_j, C} = 0 held for any polynomial H_j: here a
    // perturbation of H_j by a coordinate (not a Casimir) must be caught.
    for (const std::string name : {"rigid_body", "lotka_volterra", "henon_heiles", "nambu", "plane_quadratic"}) {
        Scene s = test::bundled(name);
        for (std::size_t k : {1, 2, 3, 4}) {
            CAPTURE(name);
            CAPTURE(k);
            const std::size_t order = 2 * ((k + 1) / 2), m = name == "nambu" ? 4 : 5;
            auto Ht = modified_hamiltonian(s.pi, s.H, k, s.realisation, m);
            const auto step = step_series(s, k, m + 2);
            CHECK(Ht[0] == s.H);
            for (std::size_t j = 1; j <= m; ++j) {
                CAPTURE(j);
                if (j < order || j % 2 == 1) CHECK(Ht[j].is_zero());
                CHECK(matched_field(s, step, Ht, j) == s.pi.hamiltonian_vector_field(Ht[j]));
            }
            CHECK_FALSE(Ht[order].is_zero());  // the leading error term is there
            auto wrong = Ht;
            wrong[order] += s.phase_space().x_gen(0);
            CHECK_FALSE(matched_field(s, step, wrong, order) == s.pi.hamiltonian_vector_field(wrong[order]));
        }
    }
}

TEST_CASE(
    "modified: the time-dt flow of Htilde agrees with one step to the truncation order, exactly as series "
    "(docs/math.md 7)") {
    // Htilde truncated after dt^m (m even, so H_{m+1} = 0 too): its time-t flow and the step agree in every
    // power t^0..t^{m+2} and differ at t^{m+3}, where the missing H_{m+2} enters.
    for (const std::string name : {"rigid_body", "lotka_volterra", "plane_quadratic"}) {
        Scene s = test::bundled(name);
        for (std::size_t k : {1, 2, 4}) {
            const std::size_t m = 4, N = m + 4;  // orders t^0..t^{m+3}
            auto Ht = modified_hamiltonian(s.pi, s.H, k, s.realisation, m);
            auto flow = flow_series(s.pi, as_series(Ht, N), N);
            auto step = step_series(s, k, N);
            CAPTURE(name);
            CAPTURE(k);
            bool differs_at_next = false;
            for (std::size_t i = 0; i < s.phase_space().dim(); ++i) {
                for (std::size_t j = 0; j <= m + 2; ++j) {
                    CAPTURE(j);
                    CHECK(flow[i][j] == step[i][j]);
                }
                differs_at_next = differs_at_next || !(flow[i][m + 3] == step[i][m + 3]);
            }
            CHECK(differs_at_next);
        }
    }
}

namespace {

// Htilde truncated after dt^m at a numeric dt, as one polynomial (dt exact as a rational).
Poly truncated_at(const std::vector<Poly>& Ht, std::size_t m, double dt) {
    return sum_powers(std::vector<Poly>(Ht.begin(), Ht.begin() + long(m) + 1), Rational::from_double(dt));
}

CompiledMap compiled_field(const Scene& s, const Poly& K) {
    return CompiledMap::build(s.pi.hamiltonian_vector_field(K), s.phase_space().coordinate_vars());
}

Eigen::VectorXd rk4_flow(const CompiledMap& f, Eigen::VectorXd x, double T, int substeps) {
    const double h = T / substeps;
    Eigen::VectorXd k1(x.size()), k2(x.size()), k3(x.size()), k4(x.size()), y(x.size());
    for (int n = 0; n < substeps; ++n) {
        f.eval(x.data(), k1.data());
        y = x + 0.5 * h * k1;
        f.eval(y.data(), k2.data());
        y = x + 0.5 * h * k2;
        f.eval(y.data(), k3.data());
        y = x + h * k3;
        f.eval(y.data(), k4.data());
        x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return x;
}

}  // namespace

TEST_CASE(
    "modified: numerically, the time-dt flow of Htilde_m matches one step to O(dt^(m+2)) (rigid body, "
    "Lotka-Volterra)") {
    // With the odd terms zero the difference is in fact O(dt^(m+3)); the fit must show at least m + 2.
    for (const std::string name : {"rigid_body", "lotka_volterra"}) {
        Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
        auto Ht = modified_hamiltonian(s.pi, s.H, 2, s.realisation, 6);
        for (std::size_t m : {2, 4}) {
            std::vector<double> logs_dt, logs_err;
            for (double dt : {0.4, 0.2, 0.1, 0.05}) {
                StepOptions opt;
                opt.k = 2;
                opt.dt = dt;
                auto st = NewtonStepper::build(s.pi, s.H, opt, x0);
                Eigen::VectorXd inc(x0.size());
                REQUIRE(st.step(x0, inc) == StepStatus::ok);
                const Eigen::VectorXd flow = rk4_flow(compiled_field(s, truncated_at(Ht, m, dt)), x0, dt, 400);
                const double err = (x0 + inc - flow).lpNorm<Eigen::Infinity>();
                if (err < 1e-14) continue;  // round-off
                logs_dt.push_back(std::log(dt));
                logs_err.push_back(std::log(err));
            }
            REQUIRE(logs_dt.size() >= 3);
            const double slope = (logs_err.front() - logs_err.back()) / (logs_dt.front() - logs_dt.back());
            CAPTURE(name);
            CAPTURE(m);
            CAPTURE(slope);
            MESSAGE(name << ": Htilde through dt^" << m << ", fitted slope " << slope);
            CHECK(slope > double(m) + 2 - 0.3);
        }
    }
}

TEST_CASE("modified: over 1e5 steps the truncated Htilde is conserved far better than H") {
    for (const std::string name : {"rigid_body", "lotka_volterra"}) {
        Scene s = test::bundled(name);
        Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
        const std::size_t k = 2, m = 4;
        auto Ht = modified_hamiltonian(s.pi, s.H, k, s.realisation, m);
        const auto vars = s.phase_space().coordinate_vars();
        CompiledMap energies = CompiledMap::build({s.H, truncated_at(Ht, m, s.dt)}, vars);
        StepOptions opt;
        opt.k = k;
        opt.dt = s.dt;
        auto st = NewtonStepper::build(s.pi, s.H, opt, x);
        double e0[2], e[2], worst[2] = {0, 0};
        energies.eval(x.data(), e0);
        auto summary = integrate_steps(st, x, 100000, [&](std::size_t, double, const Eigen::VectorXd& y) {
            energies.eval(y.data(), e);
            for (int i = 0; i < 2; ++i) worst[i] = std::max(worst[i], std::abs(e[i] - e0[i]) / std::abs(e0[i]));
            return false;
        });
        REQUIRE(summary.status == StepStatus::ok);
        CAPTURE(name);
        MESSAGE(name << ": k = 2, dt = " << s.dt << ", 1e5 steps: max relative error of H " << worst[0]
                     << ", of Htilde through dt^4 " << worst[1]);
        CHECK(worst[1] < worst[0] / 100);
    }
}

TEST_CASE("modified_hamiltonian: with the radial realisation a linear H is its own modified Hamiltonian") {
    // S_t = t H exactly (p . (alpha - x) = 0), so the step is H's flow and Htilde = H to every order;
    // the log-canonical closed form, by contrast, has H_2 != 0
    const Scene s = test::bundled("lotka_volterra");
    for (std::size_t k : {1, 2, 4}) {
        CAPTURE(k);
        const auto radial = modified_hamiltonian(s.pi, s.H, k, RealisationChoice::radial, 5);
        REQUIRE(radial.size() == 6);
        CHECK(radial[0] == s.H);
        for (std::size_t j = 1; j < radial.size(); ++j) CHECK(radial[j].is_zero());
    }
    CHECK_FALSE(modified_hamiltonian(s.pi, s.H, 2, RealisationChoice::closed_form, 2)[2].is_zero());
}
