#include "scheme/trajectory.hpp"

#include "scheme/run_loop.hpp"
#include "scheme/detail/trajectory_runner.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pgi {

std::vector<double> invariant_scales(const Scheme& scheme, std::span<const double> x, const std::vector<Poly>& extra) {
    std::vector<double> out{term_size(scheme.hamiltonian(), x)};
    for (const auto& C : scheme.casimirs()) out.push_back(term_size(C, x));
    for (const auto& f : extra) out.push_back(term_size(f, x));
    return out;
}

double relative_error(double value, double initial, double scale) {
    const double d = std::abs(value - initial);
    return scale > 0 ? d / scale : d;
}

std::string step_failure_message(const NewtonStepper& s, std::size_t step, StepStatus status) {
    char buffer[512];
    std::snprintf(
        buffer, sizeof buffer,
        "step %zu (from t = %.17g) failed: %s after %d Newton iterations, residual %.3g, last correction %.3g; "
        "a smaller dt may help",
        step, double(step - 1) * s.dt(), to_string(status).c_str(), s.last_iterations(), s.last_residual(),
        s.last_correction());
    return buffer;
}

Trajectory integrate(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end, std::size_t every,
                     const std::optional<Eigen::VectorXd>& x_typical, const TrajectoryEvents& events,
                     const RunControl& control, const ParameterValues& parameters, bool tangent,
                     std::span<const double> t_eval) {
    const std::size_t n = scheme.dim();
    if (every == 0) throw InputError("every", "must be at least 1");
    TrajectoryOptions options;
    options.every = every, options.events = events, options.tangent = tangent;
    options.t_eval.assign(t_eval.begin(), t_eval.end());
    const RunPlan plan = plan_run(trajectory_request(scheme, dt, t_end, options), control.limits);
    if (static_cast<std::size_t>(x0.size()) != n || !x0.allFinite())
        throw InputError("x0", "must have " + std::to_string(n) + " finite values");
    if (x_typical && (x_typical->size() != x0.size() || !x_typical->allFinite()))
        throw InputError("x_typical", "must have " + std::to_string(n) + " finite values");
    const RowMatrix P = scheme.parameter_rows(parameters);
    // the run's state is the extended one (x, w): w constant, its increments exactly 0 (pi's rows of w are zero)
    const auto extend = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
        return scheme.extended_states(v.transpose(), P).row(0).transpose();
    };
    TrajectoryRunner runner(scheme, dt, plan, options, extend(x_typical ? *x_typical : x0), control.cancel);
    return runner.run(extend(x0));
}

}  // namespace pgi
