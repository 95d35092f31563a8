#include "poisson/realisation.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

using namespace pgi;
using pgi::test::structure;

TEST_CASE(
    "realisation: radial recursion reproduces the Bernoulli realisation of so(3)* to degree 6 (docs/math.md 3-4)") {
    for (const auto& pi :
         {test::bundled("rigid_body").pi, structure({"x1", "x2", "x3"}, {{0, 1, "x3"}, {1, 2, "x1"}, {2, 0, "x2"}})}) {
        auto radial = radial_realisation(pi, 6);
        auto closed = lie_poisson_realisation(pi, 6);
        for (std::size_t i = 0; i < 3; ++i) {
            CAPTURE(i);
            CHECK(radial.alpha[i] == closed.alpha[i]);
            CHECK(radial.beta[i] == closed.beta[i]);
        }
    }
}

TEST_CASE("realisation: low terms of the Lie-Poisson form are x - L x/2 + L^2 x/12") {
    auto pi = test::bundled("rigid_body").pi;
    const auto& M = pi.phase_space();
    auto r = lie_poisson_realisation(pi, 2);
    // (L x)_1 = sum_j pi_1j p_j = -x3 p_x2 + x2 p_x3
    CHECK(r.alpha[0][1] == Rational(1, 2) * (M.x_gen(2) * M.p_gen(1)) - Rational(1, 2) * (M.x_gen(1) * M.p_gen(2)));
    CHECK(r.beta[0][1] == -r.alpha[0][1]);
    CHECK(r.alpha[0][2] == r.beta[0][2]);
}

TEST_CASE(
    "realisation: the three identities hold for every bundled structure, closed form and radial (docs/math.md 2)") {
    for (const auto& name : test::bundled_names()) {
        Scene s = test::bundled(name);
        for (auto choice : {RealisationChoice::automatic, RealisationChoice::radial}) {
            CAPTURE(name);
            CAPTURE(to_string(choice));
            auto r = build_realisation(s.pi, choice, 5);
            auto d = realisation_defect(s.pi, r);
            CHECK_MESSAGE(!d.has_value(), (d ? d->identity + " at " + d->defect.to_string() : ""));
        }
    }
}

TEST_CASE("realisation: radial gives valid realisations for (x^2+y^2) dx^dy and the Nambu structure to degree 6") {
    for (const auto& name : {"plane_quadratic", "nambu"}) {
        CAPTURE(name);
        Scene s = test::bundled(name);
        auto r = radial_realisation(s.pi, 6);
        CHECK(r.method == "radial");
        CHECK_FALSE(realisation_defect(s.pi, r).has_value());
        // and the radial gauge of docs/math.md 4: sum_j p_j (alpha_j - x_j) = 0
        const auto& M = s.phase_space();
        Poly gauge(M.ring());
        for (std::size_t j = 0; j < M.dim(); ++j) gauge += M.p_gen(j) * (r.alpha[j].sum() - M.x_gen(j));
        CHECK(gauge.is_zero());
    }
}

TEST_CASE("realisation: for a log-canonical structure radial and exponential are both valid and differ") {
    Scene s = test::bundled("lotka_volterra");
    auto exp_form = log_canonical_realisation(s.pi, 4);
    auto radial = radial_realisation(s.pi, 4);
    CHECK_FALSE(realisation_defect(s.pi, exp_form).has_value());
    CHECK_FALSE(realisation_defect(s.pi, radial).has_value());
    CHECK(exp_form.alpha[0][1] == radial.alpha[0][1]);  // both start x - pi p / 2
    CHECK_FALSE(exp_form.alpha[0] == radial.alpha[0]);
}

TEST_CASE("realisation: the identity check fails on a corrupted realisation and says where") {
    Scene s = test::bundled("rigid_body");
    auto r = lie_poisson_realisation(s.pi, 4);
    r.alpha[1][2] += Rational(1, 7) * s.phase_space().p_gen(0) * s.phase_space().p_gen(0);
    auto d = realisation_defect(s.pi, r);
    REQUIRE(d.has_value());
    CHECK(d->identity == "{alpha_i, alpha_j} = pi_ij(alpha)");
    CHECK(d->i == 0);
    CHECK(d->j == 1);
    CHECK(d->degree == 1);
    // the realisation of -pi is not one of pi
    const auto& M = s.phase_space();
    std::vector<std::vector<Poly>> minus(3, std::vector<Poly>(3, Poly(M.ring())));
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j) minus[i][j] = -s.pi(i, j);
    auto other = lie_poisson_realisation(PoissonStructure(M, minus), 3);
    CHECK(realisation_defect(s.pi, other).has_value());
    CHECK_FALSE(realisation_defect(PoissonStructure(M, minus), other).has_value());
}

TEST_CASE("realisation: closed-form is refused for a general structure") {
    Scene s = test::bundled("nambu");
    CHECK_THROWS_AS(build_realisation(s.pi, RealisationChoice::closed_form, 3), std::invalid_argument);
    CHECK(build_realisation(s.pi, RealisationChoice::automatic, 3).method == "radial");
    CHECK(build_realisation(test::bundled("rigid_body").pi, RealisationChoice::automatic, 3).method == "lie-poisson");
    CHECK(build_realisation(test::bundled("henon_heiles").pi, RealisationChoice::closed_form, 3).method == "constant");
}
