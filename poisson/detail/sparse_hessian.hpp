#pragma once
// grad S_dt and the Hessian of S_dt = sum_j dt^j S_j (docs/math.md 6: the Newton matrix reads Hess S_dt), dt a
// run-time argument, compiled on the Hessian's non-zero pattern: each component d_c S_j is derived only by the
// coordinates it holds, so the exact work and the compiled outputs grow with the pattern (O(n) on a lattice),
// never with n^2. The Hessian is symmetric: only its entries (r, c) with r <= c are derived and compiled (half the
// exact derivatives and about a third fewer compiled terms), and (c, r) reads the same value.
#include "poisson/dt_series.hpp"
#include "poisson/phase_space.hpp"
#include "poisson/sparse_pattern.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace pgi {

struct CompiledGradient {
    SparsePattern hessian;  // (r, c) where some d_c S_j holds x_r (a symmetric pattern)
    /// Pattern entry k's value is with_hessian's output n + hessian_value[k] (the entries r <= c numbered in
    /// pattern order; (c, r) shares the number of (r, c)).
    std::vector<std::uint32_t> hessian_value;
    DtSeriesMap with_hessian;   // (x, dt) -> grad S_dt (n values), then Hess S_dt's entries r <= c (pattern order)
    DtSeriesMap gradient;       // (x, dt) -> grad S_dt
    DtSeriesMap gradient_size;  // (|x|, dt) -> the sizes of grad S_dt's terms (every coefficient made positive)
    /// How many of S_1..S_k with_hessian's Hessian reads (k unless truncated, see compile_gradient), and, when fewer or
    /// when passive coordinates' entries are left out, the whole Hess S_dt's entries r <= c (what the tangent map
    /// needs; empty otherwise).
    std::size_t hessian_terms = 0;
    DtSeriesMap full_hessian;
};

/// The Hessian's values in pattern order (hessian.nonzeros() of them) from with_hessian's outputs past the gradient.
void expand_hessian(const CompiledGradient& g, const double* upper, double* values);

/// Where the Newton matrix may neglect S_j (compile_gradient, docs/math.md 6): at the typical state x_typical, with
/// alpha_p_size an estimate of |alpha_p|_inf there (|pi(x_typical)|_inf: alpha_p = pi / 2 + O(p)), the neglected
/// Hessian terms may move J = alpha_x + alpha_p Hess S_dt by at most `bound` (as a matrix, inf norm). Newton's
/// correction then errs by bound |dx| more, and so does p updated by the Hessian after a correction |dx| <= newton_tol
/// |x| (NewtonStepper::accept_check): bound = u / newton_tol keeps that within an ulp of |x|, a sixty-fourth of what
/// the acceptance test allows.
struct HessianTruncation {
    std::span<const double> x_typical;
    double alpha_p_size = 1;
    double bound = 0;
};

/// S = S_1..S_k, polynomials in the coordinates of M; planned_dt as for DtSeriesMap (the build's dt).
/// With a truncation (x_typical given, dense problems of at most hessian_truncation_dim coordinates), with_hessian's
/// Hessian reads only S_1..S_m, the fewest with alpha_p_size sum_{j>m} dt^j |Hess S_j(x_typical)|_inf <= bound
/// (dt = planned_dt). The Hessian serves only the Newton matrix, which sets how fast Newton
/// converges, not where: grad S_dt stays whole, and the acceptance test certifies every step as before.
/// passive[w] (empty: none) marks the coordinates whose rows of pi are zero: every realisation leaves them alone
/// (alpha_w = x_w, and no p_w enters alpha or delta), so the Newton matrix's rows for them are e_w and its columns
/// for them multiply a zero correction; with_hessian and gradient then leave out their components of grad S_dt and
/// every Hessian entry in their rows or columns (outputs 0), and full_hessian keeps the whole Hessian.
CompiledGradient compile_gradient(const PhaseSpace& M, const std::vector<Poly>& S, double planned_dt = 0,
                                  const HessianTruncation& truncation = {}, const std::vector<bool>& passive = {});
inline constexpr std::size_t hessian_truncation_dim = 8;

}  // namespace pgi
