#pragma once
// A run of a Scheme's step from x0 to t_end, observed: the trajectory every few steps, the drift of H and
// of the Casimirs, the Newton statistics, the crossings of events. What the Python module's integrate()
// returns; it runs the loop the command line's run and the ensembles run (scheme/run_loop.hpp).
#include "poisson/events.hpp"
#include "scheme/run_request.hpp"
#include "scheme/scheme.hpp"

#include <optional>
#include <span>
#include <string>
#include <vector>

namespace pgi {

/// term_size at x of H, the Casimirs, then extra: the scales of the outputs of scheme.invariants(extra).
std::vector<double> invariant_scales(const Scheme& scheme, std::span<const double> x,
                                     const std::vector<Poly>& extra = {});
/// How every report (the command line, Python, ensembles, pgi_peers) measures an invariant's drift:
/// |value - initial| / scale, scale the size of the invariant's terms at x0 (term_size), or the absolute
/// change when that is 0. Dividing by |C(x0)| instead made a Casimir through 0 report 7.0 for a drift of 2e-16.
double relative_error(double value, double initial, double scale);
/// Above this relative energy error a finished run is said to be inaccurate, in every report (the command line,
/// Python, ensembles): each step solved its equation to round-off (verified), but at this dt the method no longer
/// follows the flow of H (the rigid body at k = 1, dt = 3: 0.14).
inline constexpr double energy_warning_from = 0.1;
/// Whether a run whose largest relative energy error is this gets the warning (a NaN error too).
inline bool energy_drifted(double energy_error_max) {
    return !(energy_error_max <= energy_warning_from);
}
/// The message of a failed step: which step, from which t, why, the iterations, residual and last correction,
/// and the hint that a smaller dt may help.
std::string step_failure_message(const NewtonStepper& s, std::size_t step, StepStatus status);

struct Trajectory {
    std::size_t dim = 0;
    std::vector<double> t;              // the recorded times: 0, every `every` steps, and the last (or t_eval)
    std::vector<double> x;              // row-major, t.size() rows of dim values
    std::vector<double> energy_error;   // relative error of H at each recorded time
    std::vector<double> casimir_error;  // row-major, t.size() rows of one value per Casimir
    std::size_t steps = 0;              // steps completed
    double energy_error_max = 0;        // over every step, not only the recorded ones
    bool energy_warning = false;        // energy_drifted(energy_error_max)
    std::vector<double> casimir_error_max;
    /// Per Casimir: the least-squares slope of its signed relative error against the step (RunLoop::drift_per_step),
    /// a bias per step. Kept at round-off, a Casimir's error is a random walk and this is ~u / steps or less; a
    /// systematic drift shows as a slope that times the steps is the error itself.
    std::vector<double> casimir_drift_per_step;
    double newton_iterations_mean = 0;
    int newton_iterations_max = 0;
    StepStatus status = StepStatus::ok;
    // when status != ok: the failed step (1-based), the t it started from, its residual and the message
    std::size_t failed_step = 0;
    double failed_t = 0, failed_residual = 0;
    std::string message;
    std::vector<Crossing> crossings;  // with events: every crossing, in time order
    bool terminal_event = false;      // a terminal event ended the run: its crossing is the last row
    /// With tangent: row-major dim x dim, d x(t_last) / d x0, the product of the Jacobians of the steps taken
    /// (poisson/step_jacobian.hpp); empty without.
    std::vector<double> jacobian;
    /// The run's last state (dim values): at t_end, or a terminal crossing's, or the last reached before a failure.
    std::vector<double> x_last;
};

/// Events watched along a run: g_i(x) = 0 crossed in event i's direction, located on the dense output
/// (poisson/events.hpp); samples > 1 also tests samples - 1 interior points of each step.
struct TrajectoryEvents {
    std::vector<EventSpec> specs;
    std::size_t samples = 1;
    EventNaming naming;  // how errors name an event ("event 1", or Python's "events[0]")
};

/// What a run records and watches besides its steps: pgi::integrate's arguments, an ensemble's options.
struct TrajectoryOptions {
    std::size_t every = 1;  // rows at every `every`-th state and the last; 0: no rows (Trajectory::x_last only)
    TrajectoryEvents events;
    bool tangent = false;        // Trajectory::jacobian
    std::vector<double> t_eval;  // rows at these times instead (every is then ignored)
    /// Whether the run records more than its final state and errors: rows, crossings or a tangent map.
    bool records() const { return every > 0 || !events.specs.empty() || tangent || !t_eval.empty(); }
};

/// Options that record nothing but the final state and the errors: an ensemble's default.
inline TrajectoryOptions final_state_only() {
    TrajectoryOptions o;
    o.every = 0;
    return o;
}

/// The request a run with these options makes, for `trajectories` of them (plan_run checks it). Throws InputError
/// for tangent with a terminal event (which ends the run between steps).
RunRequest trajectory_request(const Scheme& scheme, double dt, double t_end, const TrajectoryOptions& options,
                              std::size_t trajectories = 1);

/// Integrates with scheme.stepper(dt, x_typical) (default: x_typical = x0) from x0 over plan_run's
/// steps_to_reach(t_end, dt) steps, Kahan-summed (integrate_steps), recording every `every`-th state and the last.
/// Stops at the first failed step, or non-finite state or invariant (status, failed_step, message say why; the
/// trajectory holds what came before). Throws, before any work, InputError on every = 0 or x0 of the wrong length or
/// not finite, what plan_run throws (a bad dt or t_end, a run above control.limits) and what EventSet::build throws for
/// a bad event; RunInterrupted once control.cancel is set. A given x_typical (finite, of x0's length) makes the run the
/// one an ensemble built at x_typical makes. With events, each crossing is kept and a terminal one ends the run: its
/// state at its t is the last row (terminal_event).
/// parameters: the values of the scheme's parameters (one each; the defaults where none is given), constant along
/// the run; x0, x_typical and the recorded states hold the coordinates only (Scheme::dim()); InputError as
/// Scheme::parameter_rows throws it. tangent: jacobian holds the derivative of the run's map, computed step by step
/// alongside it (InputError with a terminal event, which ends the run between steps).
/// t_eval: the rows are at these times instead (every is ignored; t equal to them, InputError from plan_run unless
/// finite, strictly increasing and in [0, t_end]), each state a true partial step of the method from the run's last
/// state before it (scheme/detail/time_output.hpp): the run itself, its final state and its jacobian are those without
/// t_eval. A partial step that fails ends the run as a failed step does (message naming the requested time); after a
/// terminal crossing the later times have no row.
Trajectory integrate(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end, std::size_t every = 1,
                     const std::optional<Eigen::VectorXd>& x_typical = std::nullopt,
                     const TrajectoryEvents& events = {}, const RunControl& control = {},
                     const ParameterValues& parameters = {}, bool tangent = false, std::span<const double> t_eval = {});

}  // namespace pgi
