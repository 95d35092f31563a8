#pragma once
// The Lagrangian bisection graph(dS_t) seen through the realisation: its source and target maps
// x -> alpha(x, grad S_t(x)) and x -> beta(x, grad S_t(x)) as exact series in t (docs/math.md 6-7).
#include "poisson/realisation.hpp"

#include <vector>

namespace pgi {

enum class Side { alpha, beta };

/// Set the result to side(x, grad S_t(x)) - x, one t-series O(t^N) per coordinate, S_t = sum_j t^j S[j-1].
/// Reads the realisation through p-degree min(N - 1, r.degree) (grad S_t = O(t)).
std::vector<Series> bisection_displacement(const PhaseSpace& M, const Realisation& r, Side side,
                                           const std::vector<Poly>& S, std::size_t N);

/// The base point of the step, xb = x + sum_{m=1..P} t^m u_m + O(t^{P+1}) with alpha(xb, grad S_t(xb)) = x:
/// the inverse of the source map. Returns u_1..u_P (index m - 1), one polynomial per coordinate. If
/// enough is given, it sees xb - x after each order (t-series exact to their order) and may stop the
/// computation early by returning true: fewer than P orders are then returned.
std::vector<std::vector<Poly>> base_point_series(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S,
                                                 std::size_t P,
                                                 const std::function<bool(const std::vector<Series>&)>& enough = {});

}  // namespace pgi
