#include "poisson/phase_space.hpp"

#include <algorithm>
#include <stdexcept>

namespace pgi {

namespace {

// The coordinates, then p_c for each coordinate c. A coordinate named as another's momentum is refused here, by
// both names: the ring would only say that one name is repeated.
std::vector<std::string> phase_space_names(const std::vector<std::string>& coordinates) {
    std::vector<std::string> names = coordinates;
    for (const auto& c : coordinates) {
        if (std::find(coordinates.begin(), coordinates.end(), "p_" + c) != coordinates.end())
            throw std::invalid_argument("coordinate 'p_" + c + "' is the name of the momentum of coordinate '" + c +
                                        "' on T*R^n: rename one of them");
        names.push_back("p_" + c);
    }
    return names;
}

}  // namespace

PhaseSpace::PhaseSpace(std::vector<std::string> coordinates, std::size_t max_terms)
    : PhaseSpace(std::move(coordinates), std::make_shared<const Budget>(BudgetLimits{.max_terms = max_terms})) {}

PhaseSpace::PhaseSpace(std::vector<std::string> coordinates, std::shared_ptr<const Budget> budget, PolyStorage storage)
    : coordinates_(std::move(coordinates)),
      coordinate_ring_(std::make_shared<const Ring>(coordinates_, budget, storage)),
      ring_(std::make_shared<const Ring>(phase_space_names(coordinates_), budget, storage)),
      momenta_(2 * coordinates_.size(), false) {
    for (std::size_t i = 0; i < dim(); ++i) momenta_[p(i)] = true;
}

std::vector<std::size_t> PhaseSpace::coordinate_vars() const {
    std::vector<std::size_t> xs;
    for (std::size_t i = 0; i < dim(); ++i) xs.push_back(x(i));
    return xs;
}

std::vector<double> PhaseSpace::point(std::span<const double> x) const {
    std::vector<double> values(ring_->size(), 0.0);
    for (std::size_t i = 0; i < dim(); ++i) values[this->x(i)] = x[i];
    return values;
}

Poly PhaseSpace::parse(std::string_view text) const {
    // Parsed in the coordinate ring (which refuses a momentum with the parser's own message, and whose
    // parser sets up n variables, not 2n), then moved: x_i keeps its index in the phase-space ring, so the
    // terms keep their order (a change of ring by composition built a (2n x n) matrix: n brackets cost n^3).
    const Poly f = Poly::parse(coordinate_ring_, text);
    std::vector<long> same(dim());
    for (std::size_t i = 0; i < dim(); ++i) same[i] = static_cast<long>(x(i));
    return rename_variables(f, ring_, same);
}

Series PhaseSpace::parse_in_time(std::string_view text) const {
    std::vector<std::string> names = coordinates_;
    names.push_back("t");
    const auto with_t = make_ring(names, ring_->budget_ptr());
    const Poly f = Poly::parse(with_t, text);
    VarMask t_only(names.size(), false);
    t_only.back() = true;
    const long degree = std::max(masked_degree(f, t_only), 0L);
    std::vector<long> map(names.size());
    for (std::size_t i = 0; i < dim(); ++i) map[i] = static_cast<long>(x(i));
    map.back() = 0;  // t is gone from every coefficient below
    Series s(ring_, static_cast<std::size_t>(degree) + 1);
    for (long m = 0; m <= degree; ++m) {
        // the coefficient of t^m: (d/dt)^m of the part homogeneous of degree m in t, over m!
        Poly c = homogeneous_part(f, t_only, static_cast<unsigned long>(m));
        for (long d = 0; d < m; ++d) c = derivative(c, names.size() - 1);
        s[static_cast<std::size_t>(m)] =
            rename_variables(inverse_factorial(static_cast<unsigned long>(m)) * c, ring_, map);
    }
    return s;
}

Poly canonical_bracket(const PhaseSpace& M, const Poly& F, const Poly& G) {
    Poly r(M.ring());
    if (F.is_zero() || G.is_zero()) return r;
    // only the variables both hold contribute (most pairs of a large sparse scene hold none)
    std::vector<bool> f(M.ring()->size()), g(M.ring()->size());
    for (std::size_t v : used_variables(F)) f[v] = true;
    for (std::size_t v : used_variables(G)) g[v] = true;
    for (std::size_t i = 0; i < M.dim(); ++i) {
        if (f[M.x(i)] && g[M.p(i)]) r += derivative(F, M.x(i)) * derivative(G, M.p(i));
        if (f[M.p(i)] && g[M.x(i)]) r -= derivative(F, M.p(i)) * derivative(G, M.x(i));
    }
    return r;
}

}  // namespace pgi
