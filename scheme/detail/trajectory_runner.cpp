#include "scheme/detail/trajectory_runner.hpp"

#include "poisson/step_jacobian.hpp"
#include "scheme/detail/time_output.hpp"

namespace pgi {

RunRequest trajectory_request(const Scheme& scheme, double dt, double t_end, const TrajectoryOptions& options,
                              std::size_t trajectories) {
    RunRequest request;
    request.dt = dt, request.t_end = t_end, request.every = options.every, request.dim = scheme.dim();
    request.invariants = 1 + scheme.casimirs().size();
    request.event_samples = options.events.samples;
    request.events = options.events.specs.size();
    request.t_eval = options.t_eval;
    request.tangent = options.tangent;
    request.trajectories = trajectories;
    if (options.tangent)
        for (const EventSpec& e : options.events.specs)
            if (e.terminal)
                throw InputError("tangent",
                                 "not with a terminal event: it ends the run between steps, and the "
                                 "tangent map is the product of whole steps' Jacobians");
    return request;
}

namespace {

// The events, built (and checked) before the step is.
std::optional<EventSet> event_set(const Scheme& scheme, const TrajectoryEvents& events) {
    if (events.specs.empty()) return std::nullopt;
    return scheme.event_set(events.specs, events.naming);
}

}  // namespace

TrajectoryRunner::TrajectoryRunner(const Scheme& scheme, double dt, const RunPlan& plan,
                                   const TrajectoryOptions& options, const Eigen::VectorXd& x_typical,
                                   const RunCancel* cancel)
    : scheme_(&scheme), options_(options), steps_(plan.steps), events_(event_set(scheme, options.events)),
      prototype_(scheme.stepper(dt, x_typical)), stepper_(prototype_), loop_(scheme) {
    loop_.set_cancel(cancel);
    if (events_) detector_prototype_.emplace(*events_, scheme.dense_output(prototype_.order()), options.events.samples);
}

Trajectory TrajectoryRunner::run(const Eigen::VectorXd& x0) {
    const std::size_t n = scheme_->dim(), C = scheme_->casimirs().size(), every = options_.every;
    stepper_ = prototype_;  // a fresh step, as a single run's
    detector_ = detector_prototype_;
    RunLoop& loop = loop_;
    NewtonStepper& stepper = stepper_;
    Trajectory r;
    r.dim = n;
    Eigen::VectorXd x = x0;
    // tangent: each step's Jacobian multiplied in after it (of the extended state: w's rows are those of I, so the
    // coordinates' block of the product is the product of the coordinates' blocks)
    std::optional<TangentProduct> product;
    if (options_.tangent) product.emplace(Eigen::Index(stepper.dim()));
    const auto add_row = [&](double t, const Eigen::VectorXd& y) {
        r.t.push_back(t);
        r.x.insert(r.x.end(), y.data(), y.data() + n);
        r.energy_error.push_back(loop.error(0));
        for (std::size_t c = 0; c < C; ++c) r.casimir_error.push_back(loop.error(1 + c));
    };
    // t_eval: rows by partial steps (the step's own state evaluated again: a partial one may come before it)
    std::optional<TimeOutput> times;
    if (!options_.t_eval.empty()) times.emplace(options_.t_eval, stepper.dt());
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
        if (!records_step(p.step, p.final, every)) return false;
        add_row(p.t, p.x);
        return false;
    };
    auto keep = [&](const Crossing& c) {
        r.crossings.push_back(c);
        return false;
    };
    const RunEnd end = loop.run(stepper, x, steps_, record, detector_ ? &*detector_ : nullptr, keep);
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
    r.x_last.assign(x.data(), x.data() + n);
    if (product) {
        r.jacobian.resize(n * n);
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            r.jacobian.data(), long(n), long(n)) = product->product().topLeftCorner(long(n), long(n));
    }
    if (output != StepStatus::ok) {  // a partial step to a requested time failed, or an invariant there
        r.status = output;
        r.failed_step = output_step;
        r.failed_t = times->time_before();
        r.failed_residual = stepper.last_residual();
        r.message = times->failure_message(stepper, output, loop.non_finite());
    } else if (!end.ok()) {
        r.failed_step = end.started ? end.steps + 1 : 0;
        r.failed_t = double(end.steps) * stepper.dt();
        r.failed_residual = stepper.last_residual();
        r.message = loop.failure_message(stepper, end);
    }
    return r;
}

}  // namespace pgi
