// Modified Hamiltonians of the Hamilton-Jacobi schemes (MATH.md 7): exact answers, structure, and the
// backward error property, exactly as series and numerically.
#include "magnus/magnus.hpp"
#include "magnus/modified_hamiltonian.hpp"
#include "poisson/bisection.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/integrate.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace pgi;

namespace {

std::vector<std::size_t> coordinate_vars(const PhaseSpace& M) {
    std::vector<std::size_t> xs;
    for (std::size_t i = 0; i < M.dim(); ++i) xs.push_back(M.x(i));
    return xs;
}

// The step of size t as exact t-series: phi_t = Phi^beta_t o (Phi^alpha_t)^{-1} (MATH.md 6).
std::vector<Series> step_series(const Scene& s, std::size_t k, std::size_t N) {
    const PhaseSpace& M = s.phase_space();
    Realisation r = build_realisation(s.pi, s.realisation, std::max(N, k));
    auto S = hamilton_jacobi_terms(M, r, s.H, k);
    auto v = inverse_near_identity(bisection_displacement(M, r, Side::alpha, S, N), coordinate_vars(M), N);
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
            for (std::size_t m = 0; m + 1 < N; ++m) shifted[m + 1] = Rational(1, static_cast<unsigned long>(n)) * next[m];
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

TEST_CASE("modified: the oscillator's midpoint rule has Htilde = (2/dt) arctan(dt/2) H = H (1 - dt^2/12 + dt^4/80 - dt^6/448)") {
    Scene s = test::bundled("harmonic_oscillator");
    auto Ht = modified_hamiltonian(s.pi, s.H, 1, RealisationChoice::automatic, 6);
    REQUIRE(Ht.size() == 7);
    CHECK(Ht[0] == s.H);
    CHECK(Ht[2] == Rational(-1, 12) * s.H);
    CHECK(Ht[4] == Rational(1, 80) * s.H);
    CHECK(Ht[6] == Rational(-1, 448) * s.H);
    for (std::size_t j : {1, 3, 5}) CHECK(Ht[j].is_zero());
}

TEST_CASE("modified: H_j = 0 below the order, odd H_j = 0, and {H_j, C} = 0 for every Casimir") {
    for (const std::string name : {"rigid_body", "lotka_volterra", "henon_heiles", "nambu", "plane_quadratic"}) {
        Scene s = test::bundled(name);
        for (std::size_t k : {1, 2, 3, 4}) {
            CAPTURE(name);
            CAPTURE(k);
            const std::size_t order = 2 * ((k + 1) / 2), m = name == "nambu" ? 4 : 6;
            auto Ht = modified_hamiltonian(s.pi, s.H, k, s.realisation, m);
            CHECK(Ht[0] == s.H);
            for (std::size_t j = 1; j <= m; ++j) {
                CAPTURE(j);
                if (j < order || j % 2 == 1) CHECK(Ht[j].is_zero());
                for (const auto& C : s.casimirs) CHECK(s.pi.bracket(Ht[j], C).is_zero());
            }
            CHECK_FALSE(Ht[order].is_zero());  // the leading error term is there
        }
    }
}

TEST_CASE("modified: the time-dt flow of Htilde agrees with one step to the truncation order, exactly as series (MATH.md 7)") {
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
