#pragma once
// Output at requested times that stays on the leaf (docs/math.md 8): each requested time tau between two states of a
// run, t_n < tau < t_n + dt, gets the state of a true step of the same method, of size tau - t_n, from the state at
// t_n; the run goes on from its own states, unchanged. A time within a step's rounding of t_n takes that state
// itself. So every row keeps the Casimirs as every step does, and the trajectory is the one the run makes without
// requested times (no interpolant: a dense output between steps would leave the leaf by its own error).
#include "poisson/newton_step.hpp"

#include <Eigen/Dense>

#include <span>
#include <string>
#include <vector>

namespace pgi {

/// One row at a requested time: its time (exactly as requested) and state (the coordinates and the parameters).
struct TimeRow {
    double t;
    const Eigen::VectorXd& x;
};

class TimeOutput {
public:
    /// Rows at `times` (as plan_run checks them: finite, strictly increasing, in [0, t_end]) for a run of steps of
    /// size dt from t = 0.
    TimeOutput(std::span<const double> times, double dt) : times_(times.begin(), times.end()), dt_(dt) {}

    /// After the run's state x at step n (t = n dt; n = 0 the start): calls emit(TimeRow) for each requested time
    /// in (t_(n-1), t], in order, by a partial step of stepper from the state before where the time is not this
    /// one (then stepper's last_* describe that partial step). t may be a terminal crossing's time, before n dt.
    /// emit returns false when its row is not a result (an invariant not finite there): non_finite. Returns ok, or
    /// the status of the partial step that failed (no row for it; failure_message says where).
    template <class Emit>
    StepStatus observe(NewtonStepper& stepper, std::size_t n, double t, const Eigen::VectorXd& x, Emit&& emit) {
        for (; next_ < times_.size() && times_[next_] <= t + rounding(); ++next_) {
            const double tau = times_[next_];
            if (n == 0 || tau >= t - rounding()) {
                if (!emit(TimeRow{tau, x})) return StepStatus::non_finite;
                continue;
            }
            const StepStatus s = partial_step(stepper, tau);
            if (s != StepStatus::ok) return s;
            if (!emit(TimeRow{tau, y_})) return StepStatus::non_finite;
        }
        before_ = x, t_before_ = t;
        return StepStatus::ok;
    }
    /// After the run's last state (observed last, at t_end or up to 1e-9 dt before it: steps_to_reach): the rows of
    /// the requested times past it, by partial steps from it. Returns as observe does.
    template <class Emit>
    StepStatus finish(NewtonStepper& stepper, Emit&& emit) {
        for (; next_ < times_.size(); ++next_) {
            const StepStatus s = partial_step(stepper, times_[next_]);
            if (s != StepStatus::ok) return s;
            if (!emit(TimeRow{times_[next_], y_})) return StepStatus::non_finite;
        }
        return StepStatus::ok;
    }
    /// After observe returned a failure: the message naming the requested time and the state it stepped from, and
    /// non_finite (RunLoop::non_finite(): the invariant that was not finite there) when not empty.
    std::string failure_message(const NewtonStepper& stepper, StepStatus status, const std::string& non_finite) const;
    /// The time of the state the last partial step started from.
    double time_before() const { return t_before_; }

private:
    double rounding() const { return 1e-12 * dt_; }  // a requested time this close to a state's is that state's
    StepStatus partial_step(NewtonStepper& stepper, double tau);

    std::vector<double> times_;
    double dt_;
    std::size_t next_ = 0;
    Eigen::VectorXd before_, y_, increment_;  // the state before this one; a partial step's state and increment
    double t_before_ = 0;
};

}  // namespace pgi
