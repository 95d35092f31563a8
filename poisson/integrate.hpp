#pragma once
// The driver, apart from the stepper (odeint's integrate_const beside do_step): N steps of size dt,
// compensated summation of the increments, an observer after every step.
#include "poisson/newton_step.hpp"

namespace pgi {

struct IntegrationSummary {
    std::size_t steps = 0;               // steps completed
    StepStatus status = StepStatus::ok;  // of the step that stopped the run, ok if none did
    double mean_iterations = 0;
};

/// x += increment with Kahan's compensation c: y = increment - c; s = x + y; c = (s - x) - y; x = s.
class CompensatedSum {
public:
    explicit CompensatedSum(Eigen::Index n) : compensation_(Eigen::VectorXd::Zero(n)) {}
    void reset() { compensation_.setZero(); }
    void add(Eigen::VectorXd& x, const Eigen::VectorXd& increment) { add(x, increment.data(), 1); }
    /// The same with increment i at increment[i stride] (a batch's structure of arrays), coordinate by coordinate:
    /// the same operations on each as above, so the same bits.
    void add(Eigen::VectorXd& x, const double* increment, std::size_t stride) {
        for (Eigen::Index i = 0; i < x.size(); ++i) {
            const double y = increment[std::size_t(i) * stride] - compensation_[i];
            const double sum = x[i] + y;
            compensation_[i] = (sum - x[i]) - y;
            x[i] = sum;
        }
    }

private:
    Eigen::VectorXd compensation_;
};

/// One trajectory between its steps, whoever steps it (integrate_steps one state at a time, the batch ensemble
/// many lanes at once): the state, its Kahan compensation, the steps and Newton iterations counted, and the status
/// that ended it. Every driver runs these operations in this order, so a trajectory's bits do not depend on it.
class TrajectoryState {
public:
    explicit TrajectoryState(Eigen::Index n) : x_(n), sum_(n) {}

    /// Starts again from x0.
    void begin(const Eigen::VectorXd& x0) {
        x_ = x0;
        sum_.reset();
        steps_ = 0, iterations_ = 0, last_iterations_ = 0;
        mean_iterations_ = 0;
        status_ = StepStatus::ok;
    }
    /// After a step that ended with status s in `iterations` Newton iterations, with its increment at inc[i stride]:
    /// true when x() is the new state, false when the run ends here (the step failed, or left a non-finite state:
    /// status() says which; a failed step is not counted).
    bool stepped(StepStatus s, int iterations, const double* inc, std::size_t stride) {
        iterations_ += iterations;
        if (s != StepStatus::ok) return end(s);
        sum_.add(x_, inc, stride);
        ++steps_;
        mean_iterations_ = double(iterations_) / double(steps_);
        last_iterations_ = iterations;
        if (!x_.allFinite()) return end(StepStatus::non_finite);
        return true;
    }
    /// Ends the run with s (a state or invariant its observer found not finite).
    bool end(StepStatus s) {
        status_ = s;
        return false;
    }

    Eigen::VectorXd& x() { return x_; }
    const Eigen::VectorXd& x() const { return x_; }
    std::size_t steps() const { return steps_; }                 // steps taken (a non-finite one included)
    double mean_iterations() const { return mean_iterations_; }  // Newton iterations per step taken
    int last_iterations() const { return last_iterations_; }     // of the last step taken
    StepStatus status() const { return status_; }

private:
    Eigen::VectorXd x_;
    CompensatedSum sum_;
    std::size_t steps_ = 0;
    long iterations_ = 0;
    int last_iterations_ = 0;
    double mean_iterations_ = 0;
    StepStatus status_ = StepStatus::ok;
};

/// Advances x by N steps (in place, through a TrajectoryState), calling observe(n, t, x) at n = 0 and after each step
/// with t = n dt, and stop = observe(...) returning true ends the run early (still ok). The increments are added with
/// Kahan compensation, so the round-off of long runs does not grow like N eps. Stops at the first step that fails; the
/// summary says which (steps) and why (status).
template <class Observer>
IntegrationSummary integrate_steps(NewtonStepper& stepper, Eigen::VectorXd& x, std::size_t N, Observer&& observe) {
    TrajectoryState state(x.size());
    Eigen::VectorXd increment = Eigen::VectorXd::Zero(x.size());
    state.begin(x);
    // (the run's length lets a long run start native code's build at its first timed step)
    struct Expecting {
        NewtonStepper& s;
        ~Expecting() { s.expect_steps(0); }
    } expecting{stepper};
    stepper.expect_steps(N);
    if (!observe(std::size_t{0}, 0.0, state.x()))
        for (std::size_t n = 1; n <= N; ++n) {
            const StepStatus s = stepper.step(state.x(), increment);
            if (!state.stepped(s, stepper.last_iterations(), increment.data(), 1)) break;
            if (observe(n, double(n) * stepper.dt(), state.x())) break;
        }
    x = state.x();
    return {state.steps(), state.status(), state.mean_iterations()};
}

}  // namespace pgi
