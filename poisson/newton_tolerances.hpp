#pragma once
// The Newton step's tolerances (docs/math.md 6), in one place for the step on one state (poisson/newton_step.cpp),
// its lanes (poisson/lane_step.ipp) and the predictor's cost model (poisson/predictor.cpp).
#include <limits>

namespace pgi {

inline constexpr double unit_roundoff = std::numeric_limits<double>::epsilon() / 2;

/// kappa of the residual's tolerance kappa u (|x| + sizes of the terms summed): evaluating a sum of terms of total
/// size T costs a few roundings of T per level of the evaluation (monomials of degree d carry ~d u each, Horner and
/// matrix products ~n u), and r = alpha - x one more: 64 covers degrees and dimensions to ~30 with room; a state off
/// by more is not a solution of the step's equation.
inline constexpr double residual_kappa = 64;

/// Simplified Newton takes over once a full correction is below this fraction of |x|.
inline constexpr double simplified_from = 1e-4;

}  // namespace pgi
