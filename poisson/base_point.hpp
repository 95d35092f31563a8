#pragma once
// The base point of the step as an exact series in the step size (the Newton predictor).
#include "poisson/realisation.hpp"

#include <vector>

namespace pgi {

/// Set the result to u_1..u_P (index 0 holds u_1) with xb = x + sum_m t^m u_m + O(t^{P+1}) solving
/// alpha(xb, grad S_t(xb)) = x, S_t = sum_j t^j S[j-1]. Each of the P fixed-point sweeps
/// u <- -(alpha - id)(x + u, grad S_t(x + u)) gains one order in t. Uses alpha up to degree min(P, D).
std::vector<std::vector<Poly>> base_point_series(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S,
                                                 std::size_t P);

}  // namespace pgi
