#include "poisson/hamilton_jacobi.hpp"

#include <doctest/doctest.h>

using namespace pgi;

namespace {

PoissonStructure structure(std::vector<std::string> coords, std::vector<std::tuple<int, int, std::string>> brackets) {
    PhaseSpace M(std::move(coords));
    std::vector<std::vector<Poly>> pi(M.dim(), std::vector<Poly>(M.dim(), Poly(M.ring())));
    for (auto& [i, j, s] : brackets) {
        pi[i][j] = M.parse(s);
        pi[j][i] = -pi[i][j];
    }
    return PoissonStructure(M, pi);
}

PoissonStructure so3() { return structure({"x1", "x2", "x3"}, {{0, 1, "x3"}, {1, 2, "x1"}, {2, 0, "x2"}}); }

}  // namespace

TEST_CASE("realisation: radial recursion matches the Lie-Poisson closed form on so(3)* (MATH.md 3-4)") {
    auto pi = so3();
    CHECK(pi.structure_class() == StructureClass::linear);
    auto radial = radial_realisation(pi, 6);
    auto closed = lie_poisson_realisation(pi, 6);
    for (std::size_t i = 0; i < 3; ++i) {
        CAPTURE(i);
        CHECK(radial.alpha[i] == closed.alpha[i]);
        CHECK(radial.beta[i] == closed.beta[i]);
    }
    CHECK_FALSE(realisation_defect(pi, closed).has_value());
    MESSAGE(closed.alpha[0].sum().to_string());
}
