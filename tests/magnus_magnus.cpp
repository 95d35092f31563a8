// The Magnus series of a time-dependent Hamiltonian (docs/math.md 7), checked exactly.
#include "magnus/magnus.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

using namespace pgi;

namespace {

// pi grad f = 0: two Hamiltonians that differ by this are the same modulo Casimirs.
bool is_casimir(const PoissonStructure& pi, const Poly& f) {
    return !pi.casimir_failure(f).has_value();
}

}  // namespace

TEST_CASE("magnus: a time-independent h gives M_eps = eps h") {
    for (const std::string name : {"nambu", "rigid_body", "lotka_volterra"}) {
        Scene s = test::bundled(name);
        Series M = magnus_series(s.pi, Series::constant(s.H, 1), 5);
        CAPTURE(name);
        CHECK(M[0].is_zero());
        CHECK(M[1] == s.H);
        for (std::size_t j = 2; j <= 5; ++j) CHECK(M[j].is_zero());
    }
}

TEST_CASE("magnus: low orders are h_0, h_1/2 and h_2/3 - {h_0, h_1}/12 (generic time-dependent h)") {
    // By hand from dM/de = h - (1/2){M,h} + (1/12){M,{M,h}} - ...: M_1 = h_0, M_2 = h_1/2, and at e^2
    // 3 M_3 = h_2 - (1/2)({M_1, h_1} + {M_2, h_0}) = h_2 - (1/2)(1 - 1/2){h_0, h_1}, so M_3 = h_2/3 + {h_1, h_0}/12
    Scene s = test::bundled("rigid_body");
    const PhaseSpace& M = s.phase_space();
    Series h = M.parse_in_time("x1*x2 + t*x3^2 + t^2*x1");
    Series Me = magnus_series(s.pi, h, 3);
    CHECK(Me[1] == h[0]);
    CHECK(Me[2] == Rational(1, 2) * h[1]);
    CHECK(Me[3] == Rational(1, 3) * h[2] + Rational(1, 12) * s.pi.bracket(h[1], h[0]));
    CHECK_FALSE(s.pi.bracket(h[1], h[0]).is_zero());  // the bracket term is really there
}

TEST_CASE(
    "magnus: symplectic Euler gives Hairer-Lubich-Wanner's modified Hamiltonian (docs/math.md 7, corrected paper "
    "example)") {
    // H = V(q) + K(p), V = q^3/3 + q^2/2, K = p^2/2 + p^4/12: h_t = K(p) + V(q - t K'(p)), and
    // M_eps = eps H - (eps^2/2) V_q K_p + (eps^3/12)(K_pp V_q^2 + V_qq K_p^2) + O(eps^4).
    auto pi = test::structure({"q", "p"}, {{0, 1, "1"}});
    const PhaseSpace& M = pi.phase_space();
    const std::string Kp = "(p + p^3/3)";
    const std::string shifted = "(q - t*" + Kp + ")";
    Series h = M.parse_in_time("p^2/2 + p^4/12 + " + shifted + "^3/3 + " + shifted + "^2/2");
    Series Me = magnus_series(pi, h, 3);
    Poly V = M.parse("q^3/3 + q^2/2"), K = M.parse("p^2/2 + p^4/12");
    Poly Vq = derivative(V, 0), Vqq = derivative(Vq, 0), Kp_ = derivative(K, 1), Kpp = derivative(Kp_, 1);
    CHECK(Me[1] == V + K);
    CHECK(Me[2] == Rational(-1, 2) * (Vq * Kp_));
    CHECK(Me[3] == Rational(1, 12) * (Kpp * Vq * Vq + Vqq * Kp_ * Kp_));
}

TEST_CASE("magnus: the Kahan step of Lotka-Volterra has Htilde = H + h^2 H^3/36 + h^4 H^5/400 (docs/math.md 7)") {
    // {x_i, x_j} = x_i x_j (i < j), H = x1 + x2 + x3, h_t = (2/t) artanh(t H/2) = H + t^2 H^3/12 + t^4 H^5/80 + ...
    auto pi = test::structure({"x1", "x2", "x3"}, {{0, 1, "x1*x2"}, {0, 2, "x1*x3"}, {1, 2, "x2*x3"}});
    const PhaseSpace& M = pi.phase_space();
    Series h = M.parse_in_time("(x1+x2+x3) + t^2*(x1+x2+x3)^3/12 + t^4*(x1+x2+x3)^5/80 + t^6*(x1+x2+x3)^7/448");
    Series Me = magnus_series(pi, h, 5);
    Poly H = M.parse("x1 + x2 + x3");
    CHECK(Me[1] == H);
    CHECK(is_casimir(pi, Me[2]));
    CHECK(is_casimir(pi, Me[3] - Rational(1, 36) * pow(H, 3)));
    CHECK(is_casimir(pi, Me[4]));
    CHECK(is_casimir(pi, Me[5] - Rational(1, 400) * pow(H, 5)));
    CHECK_FALSE(is_casimir(pi, Me[3] - Rational(1, 12) * pow(H, 3)));  // not h's own coefficient
}
