#include "poisson/phase_space.hpp"

namespace pgi {

namespace {

std::vector<std::string> phase_space_names(const std::vector<std::string>& coordinates) {
    std::vector<std::string> names = coordinates;
    for (const auto& c : coordinates) names.push_back("p_" + c);
    return names;
}

}  // namespace

PhaseSpace::PhaseSpace(std::vector<std::string> coordinates)
    : coordinates_(std::move(coordinates)),
      coordinate_ring_(make_ring(coordinates_)),
      ring_(make_ring(phase_space_names(coordinates_))),
      momenta_(2 * coordinates_.size(), false) {
    for (std::size_t i = 0; i < dim(); ++i) momenta_[p(i)] = true;
}

Poly PhaseSpace::parse(std::string_view text) const {
    Poly f = Poly::parse(coordinate_ring_, text);
    std::vector<long> map(dim());
    for (std::size_t i = 0; i < dim(); ++i) map[i] = static_cast<long>(x(i));
    return rename_variables(f, ring_, map);
}

Poly canonical_bracket(const PhaseSpace& M, const Poly& F, const Poly& G) {
    Poly r(M.ring());
    for (std::size_t i = 0; i < M.dim(); ++i) {
        r += derivative(F, M.x(i)) * derivative(G, M.p(i));
        r -= derivative(F, M.p(i)) * derivative(G, M.x(i));
    }
    return r;
}

}  // namespace pgi
