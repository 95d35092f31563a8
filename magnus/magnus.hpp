#pragma once
// The Hamiltonian Magnus series of a time-dependent Hamiltonian (docs/math.md 7, the paper's section 1).
#include "poisson/structure.hpp"

namespace pgi {

/// {A, B} of two series with polynomial coefficients, term by term: [A, B]_m = sum_{a+b=m} {A_a, B_b}.
Series poisson_bracket(const PoissonStructure& pi, const Series& A, const Series& B);

/// Set the result to M_e = M_1 e + ... + M_m e^m + O(e^{m+1}) (index 0 holds M_0 = 0), the solution of
/// dM/de = sum_i B_i/i! ad_M^i h_e, M(0) = 0, ad_M F = {M, F}, B_1 = -1/2: the time-e flow of h_t is the
/// time-1 flow of M_e. h is a t-series with polynomial coefficients (missing orders count as zero).
Series magnus_series(const PoissonStructure& pi, const Series& h, std::size_t m);

}  // namespace pgi
