#include "scheme/run_request.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pgi {

double steps_to_reach(double t_end, double dt) {
    if (t_end == 0) return 0;
    const double q = std::max(1.0, std::ceil(t_end / dt - 1e-9));
    return q < 0x1p63 ? q : std::numeric_limits<double>::infinity();
}

namespace {

// printf's formatting into a string (the core library does not link fmt).
template <class... A>
std::string format(const char* f, A... a) {
    char buffer[512];
    std::snprintf(buffer, sizeof buffer, f, a...);
    return buffer;
}

void check_domain(const RunRequest& r) {
    if (!(r.dt > 0) || !std::isfinite(r.dt)) throw InputError("dt", std::string("must be positive and finite"));
    if (!(r.t_end >= 0) || !std::isfinite(r.t_end))
        throw InputError("t_end", std::string("must be finite and not negative"));
    if (r.event_samples < 1) throw InputError("event_samples", "must be at least 1");
    if (r.trajectories < 1) throw InputError("trajectories", "must be at least 1");
    for (std::size_t i = 0; i < r.t_eval.size(); ++i) {
        const double t = r.t_eval[i];
        const std::string where = format("t_eval[%zu] = %.17g", i, t);
        if (!std::isfinite(t)) throw InputError("t_eval", where + " is not finite");
        if (t < 0 || t > r.t_end) throw InputError("t_eval", where + format(" is outside [0, t_end = %.17g]", r.t_end));
        if (i > 0 && !(t > r.t_eval[i - 1]))
            throw InputError("t_eval", where + " does not follow the time before it: the times must increase strictly");
    }
}

}  // namespace

std::size_t recorded_steps(std::size_t steps, std::size_t every) {
    if (every == 0 || steps == 0) return 1;
    return steps / every + 1 + (steps % every != 0 ? 1 : 0);
}

RunPlan plan_run(const RunRequest& r, const RunLimits& limits) {
    check_domain(r);
    const double steps = steps_to_reach(r.t_end, r.dt);
    if (!(steps <= double(limits.max_steps)))
        throw RunBudgetError(
            format("t_end / dt = %.6g / %.6g needs %.6g steps, above the step budget of %zu "
                   "(raise max_steps / --max-steps, or use a larger dt)",
                   r.t_end, r.dt, steps, limits.max_steps));
    if (r.event_samples > RunLimits::max_event_samples)
        throw RunBudgetError(format("event_samples = %zu is above the limit of %zu sign tests per step",
                                    r.event_samples, RunLimits::max_event_samples));
    if (r.events > RunLimits::max_events)
        throw RunBudgetError(format("%zu events are above the limit of %zu per run", r.events, RunLimits::max_events));
    RunPlan plan;
    plan.steps = static_cast<std::size_t>(steps);
    plan.records = r.t_eval.empty() ? recorded_steps(plan.steps, r.every) : r.t_eval.size();
    // per trajectory: its recorded rows (t, x, the invariants' errors), its start, its tangent map, and about 64
    // bytes of report
    const double per_row = 8.0 * double(1 + r.dim + r.invariants);
    const double per_trajectory = double(plan.records) * per_row + 8.0 * double(r.dim) +
                                  (r.tangent ? 8.0 * double(r.dim) * double(r.dim) : 0.0) + 64;
    plan.output_mb = double(r.trajectories) * per_trajectory / double(1 << 20);
    if (!(plan.output_mb <= limits.max_output_mb))
        throw RunBudgetError(
            format("the run would keep about %.4g MB (%zu trajector%s of %zu recorded row%s), above the "
                   "output budget of %.4g MB (%s, or raise max_output_mb / --max-output-mb)",
                   plan.output_mb, r.trajectories, r.trajectories == 1 ? "y" : "ies", plan.records,
                   plan.records == 1 ? "" : "s", limits.max_output_mb,
                   r.every == 0        ? "run fewer trajectories at once"
                   : !r.t_eval.empty() ? "request fewer times"
                                       : "record less with a larger every / --every"));
    return plan;
}

}  // namespace pgi
