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

/// Advances x by N steps (in place), calling observe(n, t, x) at n = 0 and after each step with
/// t = n dt, and stop = observe(...) returning true ends the run early (still ok). The increments
/// are added with Kahan compensation, so the round-off of long runs does not grow like N eps.
/// Stops at the first step that fails; the summary says which (steps) and why (status).
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

template <class Observer>
IntegrationSummary integrate_steps(NewtonStepper& stepper, Eigen::VectorXd& x, std::size_t N, Observer&& observe) {
    IntegrationSummary summary;
    Eigen::VectorXd increment = Eigen::VectorXd::Zero(x.size());
    CompensatedSum sum(x.size());
    long iterations = 0;
    if (observe(std::size_t{0}, 0.0, x)) return summary;
    for (std::size_t n = 1; n <= N; ++n) {
        summary.status = stepper.step(x, increment);
        iterations += stepper.last_iterations();
        if (summary.status != StepStatus::ok) break;
        sum.add(x, increment);
        summary.steps = n;
        summary.mean_iterations = double(iterations) / double(n);
        if (!x.allFinite()) {
            summary.status = StepStatus::non_finite;
            break;
        }
        if (observe(n, double(n) * stepper.dt(), x)) break;
    }
    return summary;
}

}  // namespace pgi
