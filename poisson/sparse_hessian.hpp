#pragma once
// grad S_dt and the Hessian of S_dt = sum_j dt^j S_j (docs/math.md 6: the Newton matrix reads Hess S_dt), dt a
// run-time argument, compiled on the Hessian's non-zero pattern: each component d_c S_j is derived only by the
// coordinates it holds, so the exact work and the compiled outputs grow with the pattern (O(n) on a lattice),
// never with n^2.
#include "poisson/dt_series.hpp"
#include "poisson/phase_space.hpp"
#include "poisson/sparse_pattern.hpp"

namespace pgi {

struct CompiledGradient {
    SparsePattern hessian;       // (r, c) where some d_c S_j holds x_r
    DtSeriesMap with_hessian;    // (x, dt) -> grad S_dt (n values), then Hess S_dt on the pattern (pattern order)
    DtSeriesMap gradient;        // (x, dt) -> grad S_dt
    DtSeriesMap gradient_size;   // (|x|, dt) -> the sizes of grad S_dt's terms (every coefficient made positive)
};

/// S = S_1..S_k, polynomials in the coordinates of M; planned_dt as for DtSeriesMap (the build's dt).
CompiledGradient compile_gradient(const PhaseSpace& M, const std::vector<Poly>& S, double planned_dt = 0);

}  // namespace pgi
