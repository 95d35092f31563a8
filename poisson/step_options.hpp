#pragma once
// The step's options and what its build chose (docs/math.md 6), shared by the truncation degree, the
// predictor and Newton.
#include "poisson/realisation.hpp"
#include "series/native.hpp"

#include <string>

namespace pgi {

/// How the step solves with its Newton matrix J (NewtonMatrix): dense LU, or sparse on J's pattern.
enum class NewtonSolver { dense, sparse };
/// How the step chooses: by measurement (automatic), or as asked (the tests compare the two).
enum class NewtonSolverChoice { automatic, dense, sparse };

struct StepOptions {
    std::size_t k = 2;  // Hamilton-Jacobi order
    double dt = 0.1;    // the largest dt the caller plans: the degree and predictor are chosen for it
    RealisationChoice realisation = RealisationChoice::automatic;
    std::size_t max_degree = 24;  // cap on the p-degree D of a truncated realisation
    int newton_max_iter = 100;    // evaluations, backtracking included (large steps may need 30-70)
    double newton_tol =
        1e-9;  // try the acceptance test once |dx| <= tol max(|x|, |xb|): the next correction is ~|dx|^2
    /// A truncated realisation's neglected terms at the solution, relative to |x|: 16 u (1.8e-15), so that a step
    /// that reports ok is Poisson, and keeps the Casimirs, to round-off. (At 1e-12, the Nambu scene at dt = 2, past
    /// its radial series' range, passed every step with terms of 6.6e-13 left and its Casimir off by 7.2e-13.)
    double truncation_bound = 0x1p-49;
    std::size_t predictor_order = 0;  // P of the base point's series; 0 chooses it by cost, up to max(k + 1, 8)
    NewtonSolverChoice solver =
        NewtonSolverChoice::automatic;  // the Newton matrix dense or sparse (NewtonMatrix::choose)
    /// Whether the step's compiled maps run native code (series/native.hpp) or machine code (series/machine_code.hpp):
    /// the same bits, faster steps. automatic: a kept library at once, machine code for the rest, native code built in
    /// the background once the step has run long enough (series/native_tier.hpp); never: the interpreter.
    NativePolicy native = NativePolicy::automatic;
};

/// How the step was built: the realisation's method and degree, and the size of the neglected
/// terms at the typical state (zero for exact closed forms).
struct StepInfo {
    std::string method;
    std::size_t degree = 0;  // D (0 for the log-canonical closed form, which has no truncation)
    bool exact_realisation = false;
    double truncation_estimate =
        0;  // max_{m > D} of the sizes of A_m's terms at the typical state's magnitudes / |x|_inf (probed degrees)
    std::size_t predictor_order = 0;  // the base point is predicted by its exact series in dt to this order
    NewtonSolver solver =
        NewtonSolver::dense;            // sparse: J, Hess S_dt and the realisation's derivatives on their patterns
    std::size_t native_maps = 0;        // the compiled maps that run native code (StepOptions::native), at the build
    std::size_t machine_code_maps = 0;  // the others that run machine code written in memory (series/machine_code.hpp)
    std::size_t hessian_terms =
        0;  // the S_j the Newton matrix's Hess S_dt reads (k unless truncated: compile_gradient)
};

}  // namespace pgi
