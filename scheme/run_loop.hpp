#pragma once
// The one run loop of pgi, driver and observer apart (Boost.Odeint's integrate_const and its observer):
// the driver integrate_steps (poisson/integrate.hpp: N steps, Kahan-summed) with, at every state, H, the
// Casimirs and any extra invariant evaluated and their largest relative errors kept, the events located on
// the dense output (when given), and an observer that does what its caller wants with each state: record a
// trajectory (pgi::integrate, Python), write CSV rows and show progress (the command line), keep the final
// state (each trajectory of an ensemble). All of them run this loop, so their numbers agree bit for bit.
#include "poisson/events.hpp"
#include "scheme/run_request.hpp"
#include "scheme/scheme.hpp"
#include "scheme/trajectory.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <span>
#include <string>
#include <vector>

namespace pgi {

class RunLoop;

/// What the observer sees: the state x at t after step `step` (0: the start), and through loop its
/// invariants there (values(), error(i)). final: the run's last state (step N, or a terminal crossing).
struct RunPoint {
    std::size_t step;
    double t;
    const Eigen::VectorXd& x;
    const RunLoop& loop;
    bool final;
};

/// How a run ended.
struct RunEnd {
    std::size_t steps = 0;  // the last step whose state was observed
    double t = 0;           // the time of that state (a terminal crossing's t when one stopped the run)
    StepStatus status =
        StepStatus::ok;           // ok, or why the run ended early: a failed step, a non-finite state or invariant
    bool started = false;         // the start was observed (its invariants finite)
    bool stopped = false;         // the observer or an event ended the run (not a failure)
    bool terminal_event = false;  // ... and it was a crossing (of a terminal event, or on_crossing asked)
    std::string non_finite;       // the invariant that was not finite ("H = inf"), when that ended the run
    std::size_t crossings = 0;    // reported to on_crossing
    double mean_iterations = 0;   // Newton iterations per step, the failed step included
    int max_iterations = 0;       // over the steps observed
    bool ok() const { return status == StepStatus::ok; }
};

/// Never stops the run: the default on_crossing.
struct IgnoreCrossings {
    bool operator()(const Crossing&) const { return false; }
};

class RunLoop {
public:
    /// H, the Casimirs, then extra (named extra_names, default "I1", "I2", ...), compiled once.
    explicit RunLoop(const Scheme& scheme, std::vector<Poly> extra = {}, std::vector<std::string> extra_names = {});

    /// Integrates x (in place) over N steps of stepper, calling on_state(const RunPoint&) at the start and
    /// after each step, and with events, on_crossing(const Crossing&) for each crossing in time order
    /// (before the state of the step that holds it). on_state or on_crossing returning true ends the run
    /// there (stopped), as does a terminal event, whose crossing becomes the final state (observed at the
    /// crossing's t). The run stops at a failed step, a non-finite state, or a non-finite invariant (then
    /// that state is not observed). At the end x is the last state observed.
    template <class OnState, class OnCrossing = IgnoreCrossings>
    RunEnd run(NewtonStepper& stepper, Eigen::VectorXd& x, std::size_t N, OnState&& on_state,
               EventDetector* events = nullptr, OnCrossing&& on_crossing = {});

    /// run()'s bookkeeping for a driver that steps by itself (the batch ensemble, one RunLoop per trajectory):
    /// begin(x0), then observe(x, first) at the start (first) and after each step. observe is false when an
    /// invariant at x is not finite (non_finite() names it; the state is not counted), as run() stops there.
    void begin(const Eigen::VectorXd& x0) { start(x0); }
    bool observe(const Eigen::VectorXd& x, bool first) {
        if (!evaluate(x)) return false;
        commit(first);
        return true;
    }
    /// observe(x, first) with the invariants at x already evaluated (values[i stride]: invariants()'s output i at
    /// x, as the batch ensemble evaluates them for all its lanes at once).
    bool observe_values(const double* values, std::size_t stride, bool first) {
        for (std::size_t i = 0; i < values_.size(); ++i) values_[i] = values[i * stride];
        if (!all_finite()) return false;
        commit(first);
        return true;
    }
    /// A state between the run's own (a partial step's: scheme/detail/time_output.hpp): its invariants evaluated
    /// (values() and error(i) describe it until the next state) and counted in error_max(), not in drift_per_step() (a
    /// fit against the step index). false when one is not finite (non_finite() names it).
    bool observe_between(const Eigen::VectorXd& y) {
        if (!evaluate(y)) return false;
        for (std::size_t i = 0; i < values_.size(); ++i) worst_[i] = std::max(worst_[i], error(i));
        return true;
    }
    /// H, the Casimirs and the extras, compiled (what observe evaluates).
    const CompiledMap& invariants() const { return invariants_; }
    const std::string& non_finite() const { return non_finite_; }
    /// Polled at every state observed (run(), observe(), observe_values()): once cancelled, RunInterrupted is thrown.
    void set_cancel(const RunCancel* cancel) { cancel_ = cancel; }

    /// The invariants at the state observed last: H, the Casimirs, the extras.
    const std::vector<double>& values() const { return values_; }
    /// relative_error of invariant i there (against its value at the start, on its scale at the start).
    double error(std::size_t i) const { return relative_error(values_[i], initial_[i], scale_[i]); }
    /// The largest error of each invariant over every state observed.
    const std::vector<double>& error_max() const { return worst_; }
    /// The least-squares slope of each invariant's signed relative error against the index of the state observed
    /// (0 at the start, then the step): a bias per step, which a round-off random walk has not (docs/math.md 6). The
    /// Casimirs' entries are what a run reports as casimir_drift_per_step. Kept as running sums, O(1) a state.
    std::vector<double> drift_per_step() const;
    const std::vector<std::string>& names() const { return names_; }

    /// The message of a run that ended early (end.ok() false): a failed step as step_failure_message
    /// says it, or the non-finite invariant ("step N (from t = ...) failed: non-finite invariant H = inf after
    /// the step; a smaller dt may help", or "the invariant H = inf at x0 is not finite: nothing to integrate").
    std::string failure_message(const NewtonStepper& stepper, const RunEnd& end) const;

private:
    void start(const Eigen::VectorXd& x0);
    bool evaluate(const Eigen::VectorXd& x);  // values_ at x; false (non_finite_ names it) if one is not finite
    bool all_finite();                        // values_ finite; else false, non_finite_ naming the first that is not
    void commit(bool first);                  // values_ observed: the initial values, the maxima

    const Scheme* scheme_;
    std::vector<Poly> extra_;
    CompiledMap invariants_;
    std::vector<std::string> names_;
    std::vector<double> values_, initial_, worst_, scale_;
    double fit_count_ = 0, fit_n_ = 0, fit_nn_ = 0;  // drift_per_step's sums: states, sum n, sum n^2 ...
    std::vector<double> fit_e_, fit_ne_;             // ... and per invariant sum e, sum n e
    Eigen::VectorXd last_;                           // the last state observed (the left end of the next step's events)
    std::string non_finite_;
    const RunCancel* cancel_ = nullptr;
};

template <class OnState, class OnCrossing>
RunEnd RunLoop::run(NewtonStepper& stepper, Eigen::VectorXd& x, std::size_t N, OnState&& on_state,
                    EventDetector* events, OnCrossing&& on_crossing) {
    RunEnd end;
    start(x);
    if (events) {
        events->start(x);
        events->step_crossings(stepper);  // crossings on the leaf: partial steps of the run's own method
    }
    const double dt = stepper.dt();
    const IntegrationSummary summary =
        integrate_steps(stepper, x, N, [&](std::size_t n, double t, const Eigen::VectorXd& y) {
            if (!evaluate(y)) {
                end.non_finite = non_finite_;
                return true;  // this state is not a result
            }
            if (n > 0) end.max_iterations = std::max(end.max_iterations, stepper.last_iterations());
            if (events && n > 0)
                if (const Crossing* c = report_crossings(*events, last_, y, dt, n, end.crossings, on_crossing)) {
                    end.stopped = end.terminal_event = true;
                    last_ = c->x;
                    if (!evaluate(last_)) {
                        end.non_finite = non_finite_;
                        return true;
                    }
                    commit(false);
                    end.steps = n;
                    end.t = c->t;
                    (void)on_state(RunPoint{n, c->t, last_, *this, true});
                    return true;
                }
            commit(n == 0);
            last_ = y;
            end.steps = n;
            end.t = t;
            end.started = true;
            if (on_state(RunPoint{n, t, y, *this, n == N})) end.stopped = true;
            return end.stopped;
        });
    end.status = summary.status;
    end.mean_iterations = summary.mean_iterations;
    if (!end.non_finite.empty()) end.status = StepStatus::non_finite;
    if (end.status != StepStatus::ok || end.terminal_event) x = last_;
    return end;
}

}  // namespace pgi
