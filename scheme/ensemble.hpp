#pragma once
// Ensembles: m initial states of one Scheme integrated on every core. A pool of threads (oneTBB, an arena
// of `threads` workers over chunks of trajectories) runs each trajectory through the same loop as
// pgi::integrate (scheme/run_loop: Kahan-summed, the invariants watched at every step), with one compiled
// step built for the whole ensemble and copied into each worker (with its own scratch). So a trajectory's
// numbers are those of its single run pgi::integrate(scheme, x0, dt, t_end, every, x_typical), bit for bit,
// whatever the thread count and the chunking. (With parameters the step is built once, at the typical coordinates
// with each parameter at its value of largest magnitude over the rows; the Scheme keeps it, and it serves the single
// run of a row whose values have those signs, Scheme::stepper: that run shares its bits.) A row that is not finite, or
// a step that fails, ends that trajectory with its status; the others finish.
//
// Within a chunk, trajectories are stepped in batches (poisson/batch_step: the predictor and grad, Hess S_dt
// of all lanes evaluated at once in structure of arrays, then Newton lane by lane); a lane whose trajectory
// ends takes the next row. The numbers stay the single run's bit for bit, whatever the batch size.
#include "scheme/run_request.hpp"
#include "scheme/scheme.hpp"
#include "scheme/trajectory.hpp"

#include <Eigen/Dense>

#include <optional>
#include <string>
#include <vector>

namespace pgi {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// How a trajectory of an ensemble ended: the step's own statuses (StepStatus, the single run's), plus a start
/// that was not finite. A member ends with exactly the status its single run has.
enum class TrajectoryStatus {
    ok,                      // every step solved to round-off
    newton_not_converged,    // a step's Newton did not reach round-off
    non_finite,              // a step left a non-finite state (or invariant)
    truncation_above_bound,  // a step's neglected realisation terms were above their bound
    ill_conditioned,         // a step's acceptance tolerance exceeded sqrt(u) |x|
    non_finite_start,        // the initial row was not finite: no step taken
};
/// The trajectory status of a run that ended with the step status s.
TrajectoryStatus status_of(StepStatus s);
/// The enumerator's name: "ok", "newton_not_converged", ..., "non_finite_start" (identifiers, for arrays and CSV).
std::string to_string(TrajectoryStatus s);

struct EnsembleOptions {
    std::size_t threads = 0;  // workers; 0: every core (TBB's default concurrency); at most max(256, 4 per core)
    std::size_t chunk = 0;    // trajectories per task; 0: about 8 tasks per worker, at least one batch each
    std::size_t batch =
        0;  // trajectories stepped together (lanes, at most 1024); 1: one at a time; 0: 16 below 40 coordinates, else 1
    /// The state the compiled step is built for (its realisation degree and predictor are chosen there).
    /// Default: typical_state(X0), the finite row of largest norm.
    std::optional<Eigen::VectorXd> x_typical;
    RunControl control;  // the budgets, checked before any work, and the flag that stops the run (RunInterrupted)
    /// The scheme's parameter values by name: 1 value (every trajectory) or one per row of X0 (a sweep); the defaults
    /// for those not given (Scheme::parameter_rows).
    ParameterValues parameters;
    /// What each trajectory records besides its final state and errors (every = 0: nothing, the default): rows every
    /// `every` steps or at t_eval, the crossings of events, the tangent map. Rows every `every` steps are kept on
    /// lanes (batch applies); with t_eval, events or a tangent map the trajectories run one at a time per thread,
    /// each through pgi::integrate's own code (scheme/detail/trajectory_runner.hpp).
    TrajectoryOptions record = final_state_only();
};

/// Per trajectory: how it ended and its Newton statistics.
struct EnsembleMember {
    TrajectoryStatus status = TrajectoryStatus::ok;
    std::size_t steps = 0;              // steps completed
    std::size_t failed_step = 0;        // 1-based, 0 when none failed
    double failed_t = 0, residual = 0;  // where the failed step started, its Newton residual
    double newton_iterations_mean = 0;
    int newton_iterations_max = 0;
    bool energy_warning = false;  // energy_drifted(its energy error); never for a non-finite start
    bool terminal_event = false;  // a terminal event's crossing ended it (status ok)
    std::size_t rows = 0;         // rows recorded (EnsembleResult::record_x)
};

/// A crossing of one of the ensemble's events by trajectory `row`.
struct EnsembleCrossing {
    std::size_t row = 0;
    Crossing crossing;  // its x: the coordinates only
};

struct EnsembleResult {
    Eigen::VectorXd x_typical;  // the state the step was built for (empty when no row was finite)
    std::size_t threads = 0;    // workers used
    /// m x n: the final state; for a failed trajectory the last state reached (the row itself if it was
    /// not finite).
    RowMatrix x;
    Eigen::VectorXd energy_error;  // m: the largest relative error of H over every step (NaN: non-finite start)
    RowMatrix casimir_error;       // m x c: the same for each Casimir
    std::vector<EnsembleMember> members;

    // With options.record (each trajectory's single run's, bit for bit):
    /// The times of the rows: 0, every dt, 2 every dt, ..., the last step's, or t_eval. With every, a trajectory that
    /// a terminal crossing ended has that crossing as its last row (at its own t: crossings), as its single run has.
    std::vector<double> record_t;
    /// m x record_t.size() x n, row-major: trajectory i's members[i].rows rows, then NaN.
    std::vector<double> record_x;
    std::vector<EnsembleCrossing> crossings;  // in order of trajectory, then time
    /// With record.tangent: m x n x n, row-major: d x(t_last) / d x0 of each trajectory (NaN for a non-finite start).
    std::vector<double> jacobian;
};

/// plan_run for an ensemble of m trajectories of scheme (their final states and errors kept, and what record asks):
/// what
/// integrate_ensemble checks before any work, for a caller that must know it before it holds X0 (a sampler, a
/// copy). Throws what plan_run throws.
RunPlan plan_ensemble(const Scheme& scheme, std::size_t m, double dt, double t_end, const RunLimits& limits = {},
                      const TrajectoryOptions& record = final_state_only());

/// The finite row of X0 of largest Euclidean norm (the first of equals): the default x_typical, chosen so
/// the realisation degree that keeps the truncation below round-off there suffices for the smaller rows.
/// None when no row is finite.
std::optional<Eigen::VectorXd> typical_state(const Eigen::Ref<const RowMatrix>& X0);

/// Integrates every row of X0 (m x n) over steps_to_reach(t_end, dt) steps of the step built once at
/// options.x_typical. Throws before any work what plan_run throws (InputError on dt <= 0, t_end < 0 or not
/// finite; RunBudgetError above options.control.limits), InputError on X0 without n columns, a non-finite x_typical or
/// one of the wrong length, threads or batch above their limits. Rows that are not finite are not an error:
/// they end with status non_finite_start. X0 and options.x_typical hold the coordinates only (Scheme::dim()); each row
/// runs on its extended state (x, w) with its parameter values w (options.parameters), and x_typical (given, or the
/// finite row of X0 of largest norm) is extended with each parameter's value of largest magnitude over the rows.
EnsembleResult integrate_ensemble(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                                  const EnsembleOptions& options = {});

}  // namespace pgi
