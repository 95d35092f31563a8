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
    SparsePattern hessian;       // (r, c) where some d_c S_j holds x_r (a symmetric pattern)
    /// Pattern entry k's value is with_hessian's output n + hessian_value[k] (the entries r <= c numbered in
    /// pattern order; (c, r) shares the number of (r, c)).
    std::vector<std::uint32_t> hessian_value;
    DtSeriesMap with_hessian;    // (x, dt) -> grad S_dt (n values), then Hess S_dt's entries r <= c (pattern order)
    DtSeriesMap gradient;        // (x, dt) -> grad S_dt
    DtSeriesMap gradient_size;   // (|x|, dt) -> the sizes of grad S_dt's terms (every coefficient made positive)
    /// How many of S_1..S_k with_hessian's Hessian reads (k unless truncated, see compile_gradient), and, when fewer,
    /// the whole Hess S_dt's entries r <= c (what the tangent map needs; empty otherwise).
    std::size_t hessian_terms = 0;
    DtSeriesMap full_hessian;
};

/// The Hessian's values in pattern order (hessian.nonzeros() of them) from with_hessian's outputs past the gradient.
void expand_hessian(const CompiledGradient& g, const double* upper, double* values);

/// S = S_1..S_k, polynomials in the coordinates of M; planned_dt as for DtSeriesMap (the build's dt).
/// x_typical given (dense problems of at most hessian_truncation_dim coordinates): with_hessian's Hessian reads only
/// S_1..S_m, the fewest whose neglected terms sum_{j>m} dt^j |Hess S_j(x_typical)| are at most hessian_truncation
/// times sum_j dt^j |Hess S_j(x_typical)| (max norms, dt = planned_dt). The Hessian serves only the Newton matrix,
/// whose error then contracts Newton by about that factor more (a predicted base point off by 1e-9 |x| is corrected
/// to 1e-17 |x|), and the acceptance test certifies every step as before; grad S_dt stays whole.
CompiledGradient compile_gradient(const PhaseSpace& M, const std::vector<Poly>& S, double planned_dt = 0,
                                  std::span<const double> x_typical = {});
inline constexpr double hessian_truncation = 1e-8;
inline constexpr std::size_t hessian_truncation_dim = 8;

}  // namespace pgi
