#pragma once
// Lyapunov exponents of a Scheme's step by Benettin's method: tangent vectors carried by the step's exact Jacobian
// (poisson/step_jacobian.hpp) along one run of the one run loop (scheme/run_loop.hpp), re-orthonormalised after
// every step by Householder QR, log |R_ii| summed. The vectors span the tangent space of the Casimirs' level set at
// x0 (the step maps it onto the level set's at the next state: grad C(step(x)) J = grad C(x)), so the exponents on
// the leaf come first and the c directions across it (one per Casimir) are reported as exactly 0 (docs/user-guide.md).
#include "scheme/run_request.hpp"
#include "scheme/scheme.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace pgi {

struct LyapunovSpectrum {
    std::size_t dim = 0;
    std::size_t leaf_dim = 0;       // dim - (number of Casimirs): the exponents measured
    std::vector<double> t;          // the recorded times: every `every` steps, and the last (never 0)
    std::vector<double> exponents;  // row-major, t.size() rows of dim: the estimates at t (1/time units)
    std::vector<double> spectrum;   // the last row: leaf_dim exponents in Benettin's (decreasing) order, then zeros
    std::size_t steps = 0;          // steps completed
    StepStatus status = StepStatus::ok;
    std::size_t failed_step = 0;  // when status != ok: the failed step (1-based), its start time and message
    double failed_t = 0, failed_residual = 0;
    std::string message;
};

/// The Lyapunov spectrum of scheme's step of dt from x0 over plan_run's steps_to_reach(t_end, dt) steps, recording
/// the running estimates every `every` steps and at the last. Throws, before any work, InputError on every = 0, x0 of
/// the wrong length or not finite, t_end = 0, or x0 where the Casimirs' gradients are linearly dependent (a singular
/// point of the leaves), what plan_run throws (a bad dt or t_end, a run above control.limits), and RunInterrupted
/// once control.cancel is set. A failed step ends the run (status, failed_step and message say why; the rows hold
/// what came before). parameters: the values of the scheme's parameters for the run (one each; the defaults where
/// none is given; InputError as Scheme::parameter_rows throws it), constant along it.
LyapunovSpectrum lyapunov(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end,
                          std::size_t every = 1, const RunControl& control = {},
                          const ParameterValues& parameters = {});

}  // namespace pgi
