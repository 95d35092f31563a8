#include "scheme/trajectory.hpp"

#include "poisson/step_jacobian.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/time_output.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pgi {

double term_size(const Poly& f, std::span<const double> x) {
    double s = 0;
    for (std::size_t t = 0; t < f.length(); ++t) {
        double c = std::abs(f.term_coeff(t).to_double());
        const auto e = f.term_exponents(t);
        for (std::size_t v = 0; v < x.size() && v < e.size(); ++v)
            if (e[v] != 0) c *= std::pow(std::abs(x[v]), double(e[v]));
        s += c;
    }
    return s;
}

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
    RunRequest request;
    request.dt = dt, request.t_end = t_end, request.every = every, request.dim = n;
    request.invariants = 1 + scheme.casimirs().size();
    request.event_samples = events.samples;
    request.t_eval = t_eval;
    const RunPlan plan = plan_run(request, control.limits);
    if (static_cast<std::size_t>(x0.size()) != n || !x0.allFinite())
        throw InputError("x0", "must have " + std::to_string(n) + " finite values");
    if (x_typical && (x_typical->size() != x0.size() || !x_typical->allFinite()))
        throw InputError("x_typical", "must have " + std::to_string(n) + " finite values");
    const RowMatrix P = scheme.parameter_rows(parameters);
    // the run's state is the extended one (x, w): w constant, its increments exactly 0 (pi's rows of w are zero)
    const auto extend = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
        return scheme.extended_states(v.transpose(), P).row(0).transpose();
    };
    if (tangent)
        for (const EventSpec& e : events.specs)
            if (e.terminal)
                throw InputError("tangent", "not with a terminal event: it ends the run between steps, and the "
                                            "tangent map is the product of whole steps' Jacobians");
    std::optional<EventSet> event_set;
    if (!events.specs.empty()) event_set = EventSet::build(scheme.phase_space(), events.specs, events.naming);
    NewtonStepper stepper = scheme.stepper(dt, extend(x_typical ? *x_typical : x0));
    std::optional<EventDetector> detector;
    if (event_set)
        detector.emplace(std::move(*event_set),
                         DenseOutput::build(scheme.structure(), scheme.hamiltonian(), stepper.order()), events.samples);
    const std::size_t N = plan.steps, C = scheme.casimirs().size();
    RunLoop loop(scheme);
    loop.set_cancel(control.cancel);
    Trajectory r;
    r.dim = n;
    Eigen::VectorXd x = extend(x0);
    // tangent: each step's Jacobian multiplied in after it (of the extended state: w's rows are those of I, so the
    // coordinates' block of the product is the product of the coordinates' blocks)
    std::optional<TangentProduct> product;
    if (tangent) product.emplace(Eigen::Index(stepper.dim()));
    const auto add_row = [&](double t, const Eigen::VectorXd& y) {
        r.t.push_back(t);
        r.x.insert(r.x.end(), y.data(), y.data() + n);
        r.energy_error.push_back(loop.error(0));
        for (std::size_t c = 0; c < C; ++c) r.casimir_error.push_back(loop.error(1 + c));
    };
    // t_eval: rows by partial steps (the step's own state evaluated again: a partial one may come before it)
    std::optional<TimeOutput> times;
    if (!t_eval.empty()) times.emplace(t_eval, dt);
    StepStatus output = StepStatus::ok;
    std::size_t output_step = 0;
    const auto timed_row = [&](const TimeRow& row) {
        if (!loop.observe_between(row.x)) return false;
        add_row(row.t, row.x);
        return true;
    };
    auto record = [&](const RunPoint& p) {
        if (product && p.step > 0) product->after_step(stepper);
        if (times) {
            output = times->observe(stepper, p.step, p.t, p.x, timed_row), output_step = p.step;
            return output != StepStatus::ok;
        }
        if (p.step % every != 0 && !p.final) return false;
        add_row(p.t, p.x);
        return false;
    };
    auto keep = [&](const Crossing& c) {
        r.crossings.push_back(c);
        return false;
    };
    const RunEnd end = loop.run(stepper, x, N, record, detector ? &*detector : nullptr, keep);
    if (times && end.ok() && !end.stopped) output = times->finish(stepper, timed_row), output_step = end.steps + 1;
    r.steps = end.steps;
    r.status = end.status;
    r.terminal_event = end.terminal_event;
    r.newton_iterations_mean = end.mean_iterations;
    r.newton_iterations_max = end.max_iterations;
    r.energy_error_max = loop.error_max()[0];
    r.energy_warning = energy_drifted(r.energy_error_max);
    r.casimir_error_max.assign(loop.error_max().begin() + 1, loop.error_max().begin() + 1 + long(C));
    const std::vector<double> drift = loop.drift_per_step();
    r.casimir_drift_per_step.assign(drift.begin() + 1, drift.begin() + 1 + long(C));
    if (product) {
        r.jacobian.resize(n * n);
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(r.jacobian.data(), long(n),
                                                                                          long(n)) =
            product->product().topLeftCorner(long(n), long(n));
    }
    if (output != StepStatus::ok) {  // a partial step to a requested time failed, or an invariant there
        r.status = output;
        r.failed_step = output_step;
        r.failed_t = times->time_before();
        r.failed_residual = stepper.last_residual();
        r.message = times->failure_message(stepper, output, loop.non_finite());
    } else if (!end.ok()) {
        r.failed_step = end.started ? end.steps + 1 : 0;
        r.failed_t = double(end.steps) * dt;
        r.failed_residual = stepper.last_residual();
        r.message = loop.failure_message(stepper, end);
    }
    return r;
}

}  // namespace pgi
