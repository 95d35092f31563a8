#pragma once
// NewtonStepper's internal parts, which its header (and so pgi.hpp) holds behind a pointer and does not define: the
// realisation's evaluator, the compiled maps of S_dt, the predictor, the Newton matrix and its dense algebra, and
// the realisation's values at the last point evaluated. Included by the files that step (poisson/newton_step.cpp,
// step_jacobian.cpp, the lane kernels); not installed.
#include "poisson/detail/dense_algebra.hpp"
#include "poisson/detail/newton_matrix.hpp"
#include "poisson/newton_step.hpp"
#include "poisson/predictor.hpp"
#include "poisson/realisation_eval.hpp"
#include "poisson/detail/sparse_hessian.hpp"

namespace pgi {

struct NewtonStepper::Internals {
    RealisationEvaluator realisation_;
    bool simplified_newton_ = true;  // StepRealisation::simplified_newton
    CompiledGradient
        gradient_;         // (x, dt) -> grad S_dt (n), Hess S_dt on its pattern; grad S_dt alone; its terms' sizes
    Predictor predictor_;  // (x, dt) -> xb, the base point's series in dt
    NewtonMatrix matrix_;  // the sparse path's J (its pattern and SparseLU, kept for simplified Newton)
    SparseRealisationValues sparse_values_;
    RealisationCheck check_;
    RealisationValues v_;
    DenseAlgebra algebra_;  // the dense path's J, LU and products
};

}  // namespace pgi
