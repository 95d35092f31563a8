#pragma once
// PhaseSpace: T*R^n with coordinates x_1..x_n and momenta p_x1..p_xn (docs/math.md section 2).
// Every exact object of a scene (pi, H, Casimirs, alpha, beta, S_j) is a Poly of this one ring.
#include "series/series.hpp"

#include <span>
#include <string>
#include <vector>

namespace pgi {

class PhaseSpace {
public:
    /// Requires distinct identifiers (std::invalid_argument otherwise). Momenta are named p_<coordinate>.
    /// budget bounds every operation of the exact phase in its rings (series/budget.hpp); storage is how their
    /// polynomials keep their terms (automatic: local from Ring::local_storage_from variables on).
    PhaseSpace(std::vector<std::string> coordinates, std::shared_ptr<const Budget> budget,
               PolyStorage storage = PolyStorage::automatic);
    /// With a budget of its own: the default limits with max_terms terms.
    explicit PhaseSpace(std::vector<std::string> coordinates, std::size_t max_terms = Ring::default_max_terms);

    std::size_t dim() const { return coordinates_.size(); }
    const std::vector<std::string>& coordinates() const { return coordinates_; }
    const RingPtr& ring() const { return ring_; }
    /// Ring variable indices of x_i and p_i.
    std::size_t x(std::size_t i) const { return i; }
    std::size_t p(std::size_t i) const { return dim() + i; }
    Poly x_gen(std::size_t i) const { return Poly::gen(ring_, x(i)); }
    Poly p_gen(std::size_t i) const { return Poly::gen(ring_, p(i)); }
    /// The ring indices of x_1..x_n, the inputs of every evaluator over the coordinates.
    std::vector<std::size_t> coordinate_vars() const;
    /// A value for every ring variable: the coordinates at x (dim() values), the momenta at 0; where a polynomial in
    /// the coordinates is evaluated in double at build time (evaluate in series/poly.hpp).
    std::vector<double> point(std::span<const double> x) const;
    /// The mask of the momenta, for grading by degree in p.
    const VarMask& momenta() const { return momenta_; }
    /// Parses a polynomial in the coordinates only (a momentum name is an unknown variable).
    Poly parse(std::string_view text) const;
    /// Parses a polynomial in the coordinates and the reserved time variable t, as a t-series whose
    /// order is one more than the degree in t.
    Series parse_in_time(std::string_view text) const;
    /// A series graded by p-degree in this phase space, O(p^N).
    Series zero_series(std::size_t N) const { return Series(ring_, N); }

private:
    std::vector<std::string> coordinates_;
    RingPtr coordinate_ring_;
    RingPtr ring_;
    VarMask momenta_;
};

/// The canonical bracket {F, G}_can = sum_i d_{x_i}F d_{p_i}G - d_{p_i}F d_{x_i}G (docs/math.md section 2).
Poly canonical_bracket(const PhaseSpace& M, const Poly& F, const Poly& G);

}  // namespace pgi
