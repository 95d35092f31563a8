#pragma once
// The Newton step's tolerances and decisions (docs/math.md 6), in one place for the step on one state
// (poisson/newton_step.cpp: T = double, each decision a bool), its lanes (poisson/lane_step.ipp: T = double or a
// Pack, each decision a mask over the lanes) and the predictor's cost model (poisson/predictor.cpp).
#include "poisson/lanes.hpp"

#include <cmath>
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

namespace newton_rules {

/// sqrt(u) max(|x|, |xb|): a residual's growth below it is round-off noise, and a tolerance above it means an
/// ill-conditioned step.
template <class T>
PGI_LANE_INLINE T noise(T x_norm, T xb_norm) {
    return std::sqrt(unit_roundoff) * lanes::max(x_norm, xb_norm);
}

/// Far from the solution a full correction may overshoot: back along it, halving down to 2^-20 of it (stopping at
/// 1/64 took points whose residual had grown 20-fold, from which sl(2)* at dt = 1/2 wandered off), while the
/// residual grows above the noise.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> backtracks(T residual, T good_residual, T noise, T lambda) {
    using lanes::both, lanes::negate;
    return both(both(negate(residual <= good_residual), negate(residual <= noise)), lambda > 0x1p-20);
}

/// A correction within newton_tol max(|x|, |xb|): the next would be ~its square, and p may be updated by the Hessian.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> small(T correction, double newton_tol, T scale) {
    return correction <= newton_tol * scale;
}

/// Small, or neither the correction nor the residual halving any more: Newton has reached its evaluation's
/// round-off, and the acceptance test decides.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> settled(lanes::mask_t<T> small, T correction, T previous, T residual,
                                         T previous_residual) {
    return lanes::either(small, lanes::both(correction > previous / 2, residual > previous_residual / 2));
}

/// After a full iteration: simplified Newton next (where the stepper allows it) once the correction is below
/// simplified_from |x| and not small.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> simplifies(bool allowed, lanes::mask_t<T> small, T correction, T scale) {
    const auto yes = allowed ? lanes::all_mask<T>() : lanes::none_mask<T>();
    return lanes::both(lanes::both(yes, lanes::negate(small)), correction <= simplified_from * scale);
}

/// After a kept-factor correction: simplified Newton goes on while corrections halve, else the next iteration
/// refreshes the Jacobian.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> stays_simplified(T correction, T last) {
    return correction <= last / 2;
}

/// An accepted step whose residual's tolerance exceeds the noise: ill-conditioned.
template <class T>
PGI_LANE_INLINE lanes::mask_t<T> ill_conditioned(T tolerance, T noise) {
    return lanes::negate(tolerance <= noise);
}

}  // namespace newton_rules

}  // namespace pgi
