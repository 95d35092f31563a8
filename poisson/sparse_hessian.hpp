#pragma once
// grad S and the Hessian of S (docs/math.md 6: the Newton matrix reads Hess S_dt) compiled on the Hessian's
// non-zero pattern: each component d_c S is derived only by the coordinates it holds, so the exact work and
// the compiled outputs grow with the pattern (O(n) on a lattice), never with n^2.
#include "poisson/phase_space.hpp"
#include "poisson/sparse_pattern.hpp"
#include "series/compile.hpp"

namespace pgi {

struct CompiledGradient {
    SparsePattern hessian;       // (r, c) where d_c S holds x_r
    CompiledMap with_hessian;    // x -> grad S (n values), then Hess S on the pattern (pattern order)
    CompiledMap gradient;        // x -> grad S
    CompiledMap gradient_size;   // |x| -> the sizes of grad S's terms (every coefficient made positive)
};

/// S a polynomial in the coordinates of M.
CompiledGradient compile_gradient(const PhaseSpace& M, const Poly& S);

}  // namespace pgi
