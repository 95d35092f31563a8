#include "poisson/hamilton_jacobi.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

using namespace pgi;

namespace {

std::vector<Poly> terms(const Scene& s, RealisationChoice choice, std::size_t k, std::size_t extra_degree = 0) {
    auto r = build_realisation(s.pi, choice, realisation_degree_for_order(k) + extra_degree);
    return hamilton_jacobi_terms(s.phase_space(), r, s.H, k);
}

}  // namespace

TEST_CASE(
    "hamilton_jacobi: the whole recursion gives S_2 = S_4 = S_6 = 0 for the symmetric realisations (docs/math.md 5)") {
    for (const auto& name : test::bundled_names()) {
        Scene s = test::bundled(name);
        for (auto choice : {RealisationChoice::automatic, RealisationChoice::radial}) {
            CAPTURE(name);
            CAPTURE(to_string(choice));
            const auto r = build_realisation(s.pi, choice, realisation_degree_for_order(7));
            CHECK(is_symmetric(r));
            // composed: the even terms from the recursion itself, not from the fact being checked
            const auto S = hamilton_jacobi_terms(s.phase_space(), r, s.H, 7, EvenTerms::composed);
            REQUIRE(S.size() == 7);
            CHECK(S[0] == s.H);
            CHECK(S[1].is_zero());
            CHECK(S[3].is_zero());
            CHECK(S[5].is_zero());
            // and the recursion that uses the fact (the default) gives the same terms, odd ones included
            CHECK(hamilton_jacobi_terms(s.phase_space(), r, s.H, 7) == S);
        }
    }
}

TEST_CASE("hamilton_jacobi: a realisation that is not symmetric takes the whole recursion") {
    // alpha = x + C p with C symmetric is no realisation, but the recursion is algebra: S_2 = (1/2) grad H^T C grad H,
    // not 0. With beta = x (not alpha(x, -p)) the even terms must be composed, not set to 0.
    auto pi = test::structure({"q", "p"}, {{0, 1, "1"}});
    const PhaseSpace& M = pi.phase_space();
    Realisation r{"test", 2, {}, {}};
    for (std::size_t i = 0; i < 2; ++i) {
        Series a(M.ring(), 3), b(M.ring(), 3);
        a[0] = b[0] = M.x_gen(i);
        a[1] = M.p_gen(0) + M.p_gen(1);  // C = [[1, 1], [1, 1]]
        r.alpha.push_back(a), r.beta.push_back(b);
    }
    CHECK_FALSE(is_symmetric(r));
    const Poly H = M.parse("q^2/2 + p^2/2");
    const auto S = hamilton_jacobi_terms(M, r, H, 3);
    CHECK(S[1] == M.parse("(q + p)^2/2"));
    CHECK(S == hamilton_jacobi_terms(M, r, H, 3, EvenTerms::composed));
    // the same alpha with its reflection as beta passes the test: the symmetry is read from the polynomials
    r.beta = r.alpha;
    for (auto& b : r.beta) b[1] = -b[1];
    CHECK(is_symmetric(r));
}

TEST_CASE("hamilton_jacobi: log-canonical S_3 matches an independent sympy derivation") {
    // pi = 2xy dx^dy, H = xy + x, exponential realisation; sympy, expanding exp and series in t by
    // itself (tools/bench/hj_sympy.py --check-log-canonical), gives S_3 = x^3 y^2/6 + x^3 y/6.
    auto pi = test::structure({"x", "y"}, {{0, 1, "2*x*y"}});
    const auto& M = pi.phase_space();
    Poly H = M.parse("x*y + x");
    auto S = hamilton_jacobi_terms(M, log_canonical_realisation(pi, 2), H, 3);
    CHECK(S[2] == M.parse("1/6*x^3*y^2 + 1/6*x^3*y"));
}

TEST_CASE("hamilton_jacobi: for a quadratic H on so(3)*, S_3 = H(f)/12 with f = pi grad H (derived by hand)") {
    // By hand from docs/math.md 3 and 5, H = x^T D x / 2, p = t grad H: alpha = x - (t/2) f + (t^2/12) pi(f) grad H +
    // O(t^3) with f = L(grad H) x = pi(x) grad H. In [t^2] H(alpha), grad H . pi(f) grad H = 0 (pi skew), so S_3 =
    // (1/3)(1/2)(f/2)^T D (f/2) = H(f)/12 -- and for I = (2, 1, 2/3) that is the polynomial below.
    Scene s = test::bundled("rigid_body");
    const PhaseSpace& M = s.phase_space();
    auto S = terms(s, RealisationChoice::automatic, 3);
    std::vector<Poly> images = s.pi.hamiltonian_vector_field(s.H);  // x_i -> f_i, momenta unchanged
    for (std::size_t i = 0; i < M.dim(); ++i) images.push_back(M.p_gen(i));
    CHECK(S[2] == Rational(1, 12) * substitute(s.H, images));
    CHECK(S[2] == M.parse("1/64*x1^2*x2^2 + 1/24*x1^2*x3^2 + 1/192*x2^2*x3^2"));
}

TEST_CASE("hamilton_jacobi: S_{i+1} reads alpha only through p-degree i") {
    Scene s = test::bundled("nambu");
    auto exact_degree = terms(s, RealisationChoice::radial, 5);
    auto more_degree = terms(s, RealisationChoice::radial, 5, 3);
    CHECK(exact_degree == more_degree);
    auto r = radial_realisation(s.pi, 2);
    CHECK_THROWS_AS(hamilton_jacobi_terms(s.phase_space(), r, s.H, 5), std::invalid_argument);
    CHECK_THROWS_AS(hamilton_jacobi_terms(s.phase_space(), r, s.H, 0), std::invalid_argument);
}

TEST_CASE("hamilton_jacobi: for the oscillator, S_t generates the exact flow's midpoint series") {
    // Constant pi, H = (q^2+p^2)/2: S_t = t H + t^3 S_3 + ...; with alpha = x - pi p/2 the recursion gives
    // S_3 = (1/3)[t^2] H(x - (t/2) J grad H) = (1/3)(1/8)|grad H|^2 = H/12.
    Scene s = test::bundled("harmonic_oscillator");
    auto S = terms(s, RealisationChoice::automatic, 3);
    CHECK(S[2] == Rational(1, 12) * s.H);
}

TEST_CASE("hamilton_jacobi: the radial realisation has p . (alpha - x) = 0, so a linear H has S_t = t H exactly") {
    // The radial (spray) realisation moves x orthogonally to p in every degree; then H(alpha(x, t dH)) = H(x)
    // for linear H and the Hamilton-Jacobi recursion stops at S_1: the step is H's exact flow.
    for (const char* name : {"lotka_volterra", "volterra_chain", "rigid_body", "nambu", "plane_quadratic"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const PhaseSpace& M = s.phase_space();
        const auto r = build_realisation(s.pi, RealisationChoice::radial, 6);
        for (std::size_t m = 1; m <= 6; ++m) {
            Poly dot(M.ring());
            for (std::size_t i = 0; i < M.dim(); ++i) dot += M.p_gen(i) * r.alpha[i][m];
            CHECK(dot.is_zero());
        }
    }
    for (const char* name : {"lotka_volterra", "volterra_chain"}) {  // H = sum x_i
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const auto S = terms(s, RealisationChoice::radial, 7);
        CHECK(S[0] == s.H);
        for (std::size_t j = 1; j < S.size(); ++j) CHECK(S[j].is_zero());
        // the log-canonical closed form is not radial: its S_3 is not zero
        CHECK_FALSE(terms(s, RealisationChoice::closed_form, 3)[2].is_zero());
    }
}
