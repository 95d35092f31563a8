#pragma once
// PoissonStructure: a skew matrix pi(x) of polynomials, its class, its bracket and its checks (docs/math.md section 1).
#include "poisson/phase_space.hpp"

#include <array>
#include <map>
#include <optional>
#include <utility>
#include <string>
#include <vector>

namespace pgi {

/// The classes that have a closed-form realisation (docs/math.md section 3), and the rest.
enum class StructureClass { constant, linear, log_canonical, general };
std::string to_string(StructureClass c);

/// The non-zero jacobiator of the first failing triple i < j < k.
struct JacobiFailure {
    std::size_t i, j, k;
    Poly jacobiator;
};

/// A Casimir C with pi grad C != 0: the first non-zero component (pi grad C)_i.
struct CasimirFailure {
    std::size_t component;
    Poly value;
};

class PoissonStructure {
public:
    /// pi[i][j] in the coordinates of M. Requires an n x n matrix with pi[i][i] = 0 and
    /// pi[j][i] = -pi[i][j]: std::invalid_argument names the first (i, j) where this fails.
    /// The Jacobi identity is not required here: check it with jacobi_failure().
    PoissonStructure(PhaseSpace M, std::vector<std::vector<Poly>> pi);
    /// The same from the entries pi_ij (i, j) alone, both orders of each pair (absent ones are 0): no n x n of
    /// polynomials (a 1000-site lattice has 2000 entries, not 10^6).
    PoissonStructure(PhaseSpace M, std::map<std::pair<std::size_t, std::size_t>, Poly> entries);

    const PhaseSpace& phase_space() const { return M_; }
    std::size_t dim() const { return M_.dim(); }
    /// pi_ij (a zero polynomial where the structure has no entry).
    const Poly& operator()(std::size_t i, std::size_t j) const;
    StructureClass structure_class() const { return class_; }
    /// For a log-canonical structure, a_ij with pi_ij = a_ij x_i x_j.
    Rational log_canonical_coefficient(std::size_t i, std::size_t j) const;

    /// The j with pi_ij != 0, increasing (pi_ji != 0 too, by skew-symmetry): the structure's pattern.
    std::vector<std::size_t> row_support(std::size_t i) const;
    /// n less the trailing coordinates that have no bracket and that no bracket holds (a scheme's parameters), or n
    /// when no coordinate has one: those stay put under every flow and scale none of the brackets, so a step measures
    /// sizes (its tolerances, its predictor's error, its realisation's truncation) over the coordinates before them.
    /// (A Casimir coordinate that a bracket holds, z in {x, y} = z, scales the flow: it counts.)
    std::size_t moving_dimension() const;

    /// {f, g} = grad f^T pi grad g.
    Poly bracket(const Poly& f, const Poly& g) const;
    /// The Hamiltonian vector field pi grad H.
    std::vector<Poly> hamiltonian_vector_field(const Poly& H) const;
    /// sum_l pi_il d_l pi_jk + pi_jl d_l pi_ki + pi_kl d_l pi_ij (l only over the variables the
    /// differentiated entry holds).
    Poly jacobiator(std::size_t i, std::size_t j, std::size_t k) const;
    /// The triples i < j < k, in lexicographic order, whose jacobiator can be non-zero: a term
    /// pi_il d_l pi_jk needs pi_jk to hold x_l and pi_il != 0. Every other jacobiator is 0 term by term,
    /// so the Jacobi check costs in proportion to the brackets, not to n^3 (none for a bracket-free scene).
    std::vector<std::array<std::size_t, 3>> jacobi_support() const;
    /// The first triple (in lexicographic order) where the Jacobi identity fails, if any.
    std::optional<JacobiFailure> jacobi_failure() const;
    /// Whether pi grad C = 0, exactly; the failing component if not.
    std::optional<CasimirFailure> casimir_failure(const Poly& C) const;

private:
    PhaseSpace M_;
    // Only the non-zero entries are kept (O(brackets), not n^2 polynomials): for each row i, j (increasing),
    // pi_ij and the coordinates x_l it holds.
    struct Entry {
        std::size_t j;
        std::vector<std::size_t> vars;
        Poly value;
    };
    Poly zero_;
    std::vector<std::vector<Entry>> rows_;
    const std::vector<std::size_t>& entry_vars(std::size_t i, std::size_t j) const;
    StructureClass class_;
};

}  // namespace pgi
