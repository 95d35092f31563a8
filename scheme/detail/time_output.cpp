#include "scheme/detail/time_output.hpp"

#include <cmath>
#include <cstdio>

namespace pgi {

StepStatus TimeOutput::partial_step(NewtonStepper& stepper, double tau) {
    const StepStatus s = stepper.step(before_, tau - t_before_, increment_);
    if (s != StepStatus::ok) return s;
    y_ = before_ + increment_;
    return y_.allFinite() ? StepStatus::ok : StepStatus::non_finite;
}

std::string TimeOutput::failure_message(const NewtonStepper& stepper, StepStatus status,
                                        const std::string& non_finite) const {
    char buffer[400];
    std::snprintf(buffer, sizeof buffer,
                  "the partial step to the requested time t = %.17g (from t = %.17g, of size %.6g) failed: %s after "
                  "%d Newton iterations, residual %.3g",
                  times_[next_], t_before_, times_[next_] - t_before_, to_string(status).c_str(),
                  stepper.last_iterations(), stepper.last_residual());
    return non_finite.empty() ? buffer : buffer + (" (the invariant " + non_finite + " there is not finite)");
}

}  // namespace pgi
