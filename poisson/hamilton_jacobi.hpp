#pragma once
// The Hamilton-Jacobi terms S_1..S_k of the paper's theorem "num_csq" (docs/math.md section 5).
#include "poisson/realisation.hpp"

#include <vector>

namespace pgi {

/// The p-degree of alpha that S_1..S_k need: S_{i+1} reads alpha only up to degree i.
inline std::size_t realisation_degree_for_order(std::size_t k) {
    return k == 0 ? 0 : k - 1;
}

/// How the even terms S_2, S_4, ... are found. from_symmetry: when the realisation is symmetric (is_symmetric)
/// they are 0 (docs/math.md 5) and not composed, and the odd ones compose only the parts of G = H o alpha whose
/// p-degree has their parity, the others vanishing along the odd gradient; composed: the whole recursion, for
/// any realisation (what the tests check the fact with).
enum class EvenTerms { from_symmetry, composed };

/// Set the result to S_1..S_k (index 0 holds S_1): S_1 = H and
/// S_{i+1} = 1/(i+1) [t^i] H(alpha(x, grad S_t^(i)(x))), S_t^(i) = sum_{j<=i} t^j S_j.
/// Requires k >= 1 and r.degree >= k - 1 (std::invalid_argument otherwise), and r a bi-realisation of pi (as
/// every build_realisation is; from_symmetry relies on it); reads alpha only up to the degree each term needs.
std::vector<Poly> hamilton_jacobi_terms(const PhaseSpace& M, const Realisation& r, const Poly& H, std::size_t k,
                                        EvenTerms even = EvenTerms::from_symmetry);

}  // namespace pgi
