// Modified Hamiltonians of splitting methods (magnus/splitting): the BCH terms against a hand computation,
// their structure (symmetric methods have even powers only, Yoshida's composition is of order 4), and the
// order to which a splitting's orbit keeps the truncated series, measured with exact kick and drift flows.
#include "magnus/modified_hamiltonian.hpp"
#include "magnus/polynomial_flow.hpp"
#include "magnus/polynomial_in.hpp"
#include "magnus/splitting.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace pgi;

namespace {

struct Split {
    PoissonStructure pi;
    Poly A, B;  // A = V(q), B = T(p)
};

Split oscillator() {
    auto pi = test::structure({"q", "p"}, {{0, 1, "1"}});
    const auto& M = pi.phase_space();
    return {pi, M.parse("q^2/2"), M.parse("p^2/2")};
}

Split henon_heiles() {
    Scene s = test::bundled("henon_heiles");
    const auto& M = s.phase_space();
    Poly A = M.parse("(q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3");
    return {s.pi, A, s.H - A};
}

// the maximum over n of |Htilde_m(x_n) - Htilde_m(x_0)| along N steps of dt from x0
double drift(const Split& s, const SplittingModified& Ht, double dt, double T, std::vector<double> x) {
    auto A = PolynomialFlow::build(s.pi, s.A), B = PolynomialFlow::build(s.pi, s.B);
    REQUIRE(A);
    REQUIRE(B);
    const double h0 = Ht.evaluate(x, dt);
    double worst = 0;
    for (long n = 0, N = std::lround(T / dt); n < N; ++n) {
        splitting_step(Ht.method, *A, *B, dt, x);
        worst = std::max(worst, std::abs(Ht.evaluate(x, dt) - h0));
    }
    return worst;
}

// least-squares slope of log(err) against log(dt)
double fitted_slope(const std::vector<double>& dts, const std::vector<double>& errs) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0, n = double(dts.size());
    for (std::size_t i = 0; i < dts.size(); ++i) {
        const double x = std::log(dts[i]), y = std::log(errs[i]);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

// The drift of Htilde through dt^m over t = 10 falls like dt^slope: fitted on dts, within 0.3 (the O(dt)
// correction moves a slope by less, a wrong term by at least 1).
struct SlopeCase {
    SplittingMethod method;
    std::size_t m;
    double slope;
};
void check_conservation_slopes(const Split& s, const std::vector<double>& x0, const std::vector<double>& dts,
                               std::initializer_list<SlopeCase> cases) {
    for (const SlopeCase& c : cases) {
        auto Ht = splitting_modified_hamiltonian(s.pi, s.A, s.B, c.method, c.m);
        std::vector<double> errs;
        for (double dt : dts) errs.push_back(drift(s, Ht, dt, 10, x0));
        const double slope = fitted_slope(dts, errs);
        INFO(to_string(c.method), " through dt^", c.m, ": slope ", slope, ", drifts ", errs[0], " .. ", errs.back());
        CHECK(std::abs(slope - c.slope) < 0.3);
    }
}

}  // namespace

TEST_CASE("compose_flows: the first BCH terms in our flow convention, exactly") {
    // Z = X + Y + (1/2){Y, X} + (1/12)({{Y, X}, X} - {{Y, X}, Y}) + O(e^4) for phi^Y_1 o phi^X_1, the
    // standard BCH with the bracket reversed ([D_F, D_G] = -D_{F,G} for D_F f = {f, F})
    Split s = oscillator();
    const auto& M = s.pi.phase_space();
    Series X(M.ring(), 4), Y(M.ring(), 4);
    X[1] = s.A;
    Y[1] = s.B;
    Series Z = compose_flows(s.pi, X, Y, 4);
    CHECK(Z[0].is_zero());
    CHECK(Z[1] == s.A + s.B);
    // by hand: {p^2/2, q^2/2} = -pq; {-pq, q^2/2} = q^2; {-pq, p^2/2} = -p^2
    CHECK(Z[2] == M.parse("-p*q/2"));
    CHECK(Z[3] == M.parse("(q^2 + p^2)/12"));
}

TEST_CASE("Lie-Trotter on Henon-Heiles: H_1 and H_2 by hand, and Hairer-Lubich-Wanner's symplectic Euler") {
    // kick by V then drift by T is docs/math.md's symplectic Euler: Htilde = H - (dt/2) T_p V_q
    // + (dt^2/12)(|V_q|^2 + p^T V_qq p) + O(dt^3)
    Split s = henon_heiles();
    const auto& M = s.pi.phase_space();
    auto Ht = splitting_modified_hamiltonian(s.pi, s.A, s.B, SplittingMethod::lie_trotter, 2);
    REQUIRE(Ht.H.size() == 3);
    CHECK(Ht.H[0][0] == s.A + s.B);
    CHECK(Ht.H[1][0] == M.parse("-(p1*(q1 + 2*q1*q2) + p2*(q2 + q1^2 - q2^2))/2"));
    CHECK(Ht.H[2][0] == M.parse("((q1 + 2*q1*q2)^2 + (q2 + q1^2 - q2^2)^2 "
                                "+ (1 + 2*q2)*p1^2 + 4*q1*p1*p2 + (1 - 2*q2)*p2^2)/12"));
}

TEST_CASE("Strang: only even powers; the oscillator's H_2 by hand (velocity Verlet keeps p^2 + (1 - dt^2/4) q^2)") {
    Split s = oscillator();
    const auto& M = s.pi.phase_space();
    auto Ht = splitting_modified_hamiltonian(s.pi, s.A, s.B, SplittingMethod::strang, 5);
    CHECK(Ht.H[1][0].is_zero());
    CHECK(Ht.H[3][0].is_zero());
    CHECK(Ht.H[5][0].is_zero());
    CHECK(Ht.H[2][0] == M.parse("p^2/12 - q^2/24"));
    Split h = henon_heiles();
    auto Hh = splitting_modified_hamiltonian(h.pi, h.A, h.B, SplittingMethod::strang, 3);
    CHECK(Hh.H[1][0].is_zero());
    CHECK(Hh.H[3][0].is_zero());
    CHECK_FALSE(Hh.H[2][0].is_zero());
}

TEST_CASE("Yoshida over Q(w): order 4 and symmetric, exactly (H_1 = H_2 = H_3 = H_5 = 0, H_4 != 0)") {
    Split s = henon_heiles();
    auto Ht = splitting_modified_hamiltonian(s.pi, s.A, s.B, SplittingMethod::yoshida, 5);
    REQUIRE(Ht.H[0].size() == 3);
    CHECK(Ht.H[0][0] == s.A + s.B);
    CHECK(Ht.H[0][1].is_zero());
    CHECK(Ht.H[0][2].is_zero());
    for (std::size_t j : {1, 2, 3, 5})
        for (std::size_t c = 0; c < 3; ++c) CHECK(Ht.H[j][c].is_zero());
    CHECK_FALSE((Ht.H[4][0].is_zero() && Ht.H[4][1].is_zero() && Ht.H[4][2].is_zero()));
    CHECK(std::abs(6 * std::pow(yoshida_weight(), 3) - 12 * std::pow(yoshida_weight(), 2) + 6 * yoshida_weight() - 1) <
          1e-14);
}

TEST_CASE("PolynomialFlow: kicks and drifts are exact, a rotation is refused") {
    Split s = oscillator();
    auto A = PolynomialFlow::build(s.pi, s.A);
    REQUIRE(A);
    CHECK(A->nilpotency() == 2);
    std::vector<double> x{0.5, 1.0};
    A->apply(0.25, x);  // p -= t q
    CHECK(x[0] == 0.5);
    CHECK(x[1] == 1.0 - 0.25 * 0.5);
    CHECK_FALSE(PolynomialFlow::build(s.pi, s.A + s.B));
}

TEST_CASE("The splitting's orbit keeps Htilde through dt^m to O(dt^{m+1}): fitted slopes on Henon-Heiles") {
    // Over a fixed time T the truncated modified Hamiltonian drifts by C dt^{m+1} (1 + O(dt)); with dt from
    // 0.2 to 0.025 the O(dt) correction moves a fitted slope by well under 0.3, while a wrong term
    // (sign, coefficient) drops it by at least one; round-off (1e-16 x steps) stays far below the drifts.
    Split s = henon_heiles();
    const std::vector<double> x0{0.1, -0.1, 0.2, 0.1}, dts{0.2, 0.1, 0.05, 0.025};
    check_conservation_slopes(
        s, x0, dts,
        {SlopeCase{SplittingMethod::lie_trotter, 0, 1}, SlopeCase{SplittingMethod::lie_trotter, 1, 2},
         SlopeCase{SplittingMethod::lie_trotter, 2, 3}, SlopeCase{SplittingMethod::strang, 0, 2},
         SlopeCase{SplittingMethod::strang, 2, 4}, SlopeCase{SplittingMethod::yoshida, 0, 4},
         SlopeCase{SplittingMethod::yoshida, 4, 6}});
}

TEST_CASE("The same on the harmonic oscillator: Strang through dt^2 and dt^4, Lie-Trotter through dt^2") {
    Split s = oscillator();
    const std::vector<double> x0{1.0, 0.0}, dts{0.2, 0.1, 0.05, 0.025};
    check_conservation_slopes(s, x0, dts,
                              {SlopeCase{SplittingMethod::lie_trotter, 2, 3}, SlopeCase{SplittingMethod::strang, 2, 4},
                               SlopeCase{SplittingMethod::strang, 4, 6}});
    // symplectic Euler keeps q^2 + p^2 - dt q p exactly, and Lie-Trotter's series through an odd power is a
    // multiple of it ((1 + dt^2/6 + ...)(q^2 + p^2 - dt q p)/2): its drift is round-off only
    for (std::size_t m : {1, 3}) {
        auto Ht = splitting_modified_hamiltonian(s.pi, s.A, s.B, SplittingMethod::lie_trotter, m);
        for (double dt : dts) CHECK(drift(s, Ht, dt, 10, x0) < 1e-13);
    }
}

TEST_CASE("as_polynomial_in: the midpoint rule's H_2 = -H/12 and H_4 = H/80; the rigid body's H_2 is not in H and C") {
    Scene ho = test::bundled("harmonic_oscillator");
    auto Ht = modified_hamiltonian(ho.pi, ho.H, 1, ho.realisation, 4);
    auto q2 = as_polynomial_in(Ht[2], {ho.H}, {"H"});
    REQUIRE(q2);
    CHECK(*q2 == Rational(-1, 12) * Poly::gen(q2->ring(), 0));
    auto q4 = as_polynomial_in(Ht[4], {ho.H}, {"H"});
    REQUIRE(q4);
    CHECK(*q4 == Rational(1, 80) * Poly::gen(q4->ring(), 0));
    // x1^4, x2^4, x3^4 in a H^2 + b H C + c C^2 form a Vandermonde system in the inverse inertias: only
    // zero has none, and H_2 = -x1^2 x2^2/64 - ... has none
    Scene rb = test::bundled("rigid_body");
    auto Hr = modified_hamiltonian(rb.pi, rb.H, 2, rb.realisation, 2);
    CHECK_FALSE(as_polynomial_in(Hr[2], {rb.H, rb.casimirs[0]}, {"H", "C1"}));
    // a product found exactly: (H + C)^2 - 3 C
    auto f = as_polynomial_in(pow(rb.H + rb.casimirs[0], 2) - Rational(3) * rb.casimirs[0], {rb.H, rb.casimirs[0]},
                              {"H", "C1"});
    REQUIRE(f);
    CHECK(f->to_string() == Poly::parse(f->ring(), "H^2 + 2*H*C1 + C1^2 - 3*C1").to_string());
}

TEST_CASE("compose_flows is the group law: associative and with inverses, exactly through e^5") {
    Split s = henon_heiles();
    const auto& M = s.pi.phase_space();
    const std::size_t N = 6;
    auto series = [&](const std::string& f) {
        Series r(M.ring(), N);
        r[1] = M.parse(f);
        return r;
    };
    const Series X = series("q1^2*q2 + p1"), Y = series("p1^2/2 + q2*p2"), Z = series("q1*p2 - q2^3/3");
    CHECK(compose_flows(s.pi, compose_flows(s.pi, X, Y, N), Z, N) ==
          compose_flows(s.pi, X, compose_flows(s.pi, Y, Z, N), N));
    const Series zero(M.ring(), N);
    CHECK(compose_flows(s.pi, X, Rational(-1) * X, N) == zero);
    // flows of one Hamiltonian commute and add: Z(X, 2X) = 3X
    CHECK(compose_flows(s.pi, X, Rational(2) * X, N) == Rational(3) * X);
}
