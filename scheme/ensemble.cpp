#include "scheme/ensemble.hpp"

#include "scheme/input.hpp"
#include "scheme/run_loop.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pgi {

std::string to_string(TrajectoryStatus s) {
    switch (s) {
        case TrajectoryStatus::ok: return "ok";
        case TrajectoryStatus::newton_not_converged: return "newton_not_converged";
        case TrajectoryStatus::non_finite: return "non_finite";
        case TrajectoryStatus::non_finite_start: return "non_finite_start";
    }
    return "?";
}

std::optional<Eigen::VectorXd> typical_state(const Eigen::Ref<const RowMatrix>& X0) {
    std::optional<Eigen::Index> best;
    double best_norm = -1;
    for (Eigen::Index i = 0; i < X0.rows(); ++i) {
        if (!X0.row(i).allFinite()) continue;
        const double norm = X0.row(i).squaredNorm();
        if (norm > best_norm) best = i, best_norm = norm;
    }
    if (!best) return std::nullopt;
    return Eigen::VectorXd(X0.row(*best).transpose());
}

namespace {

// What one worker owns: its copy of the compiled step (reset from the prototype before each trajectory, so
// a trajectory starts from the state a single run's fresh stepper has), of the run loop (its compiled
// invariants and scratch), and the state.
struct Worker {
    const NewtonStepper* prototype;
    NewtonStepper stepper;
    RunLoop loop;
    Eigen::VectorXd x;

    Worker(const NewtonStepper& p, const RunLoop& l) : prototype(&p), stepper(p), loop(l), x(Eigen::Index(p.dim())) {}
};

TrajectoryStatus status_of(StepStatus s) {
    return s == StepStatus::newton_not_converged ? TrajectoryStatus::newton_not_converged
         : s == StepStatus::non_finite           ? TrajectoryStatus::non_finite
                                                 : TrajectoryStatus::ok;
}

// A row that is not finite: kept as it is, no step taken, its errors NaN.
void end_non_finite_start(const Eigen::Ref<const RowMatrix>& X0, Eigen::Index i, EnsembleResult& r) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.x.row(i) = X0.row(i);
    r.members[std::size_t(i)].status = TrajectoryStatus::non_finite_start;
    r.energy_error(i) = nan;
    r.casimir_error.row(i).setConstant(nan);
}

// One trajectory: the run loop of pgi::integrate (scheme/run_loop.hpp) with an observer that keeps nothing
// (the loop leaves x at the last state observed).
void run_one(Worker& w, const Eigen::Ref<const RowMatrix>& X0, std::size_t N, double dt, Eigen::Index i, EnsembleResult& r) {
    if (!X0.row(i).allFinite()) return end_non_finite_start(X0, i, r);
    EnsembleMember& m = r.members[std::size_t(i)];
    w.stepper = *w.prototype;
    w.x = X0.row(i).transpose();
    const RunEnd end = w.loop.run(w.stepper, w.x, N, [](const RunPoint&) { return false; });
    r.x.row(i) = w.x.transpose();
    m.status = status_of(end.status);
    m.steps = end.steps;
    m.newton_iterations_mean = end.mean_iterations;
    m.newton_iterations_max = end.max_iterations;
    r.energy_error(i) = w.loop.error_max()[0];
    for (Eigen::Index c = 0; c < r.casimir_error.cols(); ++c) r.casimir_error(i, c) = w.loop.error_max()[std::size_t(1 + c)];
    if (!end.ok()) {
        m.failed_step = end.started ? end.steps + 1 : 0;
        m.failed_t = double(end.steps) * dt;
        m.residual = w.stepper.last_residual();
    }
}

// The one place that advances a chunk of trajectories (a batch step would go here).
void run_chunk(Worker& w, const Eigen::Ref<const RowMatrix>& X0, std::size_t N, double dt, std::size_t begin,
               std::size_t end, EnsembleResult& r) {
    for (std::size_t i = begin; i < end; ++i) run_one(w, X0, N, dt, Eigen::Index(i), r);
}

void check_arguments(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                     const EnsembleOptions& options) {
    const auto n = Eigen::Index(scheme.phase_space().dim());
    if (X0.cols() != n)
        throw InputError("X0", "must have " + std::to_string(n) + " columns (one per coordinate), got " + std::to_string(X0.cols()));
    if (!(dt > 0) || !std::isfinite(dt)) throw InputError("dt", "must be positive and finite");
    if (!(t_end >= 0) || !std::isfinite(t_end)) throw InputError("t_end", "must be finite and not negative");
    const std::size_t most = std::max<std::size_t>(256, 4 * std::size_t(tbb::info::default_concurrency()));
    if (options.threads > most)
        throw InputError("threads", std::to_string(options.threads) + " is above the limit of " + std::to_string(most) + " (4 per core, at least 256)");
    if (const auto& xt = options.x_typical) {
        if (xt->size() != n) throw InputError("x_typical", "must have " + std::to_string(n) + " values, got " + std::to_string(xt->size()));
        if (!xt->allFinite()) throw InputError("x_typical", "must be finite");
    }
}

}  // namespace

EnsembleResult integrate_ensemble(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                                  const EnsembleOptions& options) {
    check_arguments(scheme, X0, dt, t_end, options);
    const Eigen::Index m = X0.rows(), n = X0.cols();
    EnsembleResult r;
    r.threads = options.threads ? options.threads : std::size_t(tbb::info::default_concurrency());
    r.x = RowMatrix::Zero(m, n);
    r.energy_error = Eigen::VectorXd::Zero(m);
    r.casimir_error = RowMatrix::Zero(m, Eigen::Index(scheme.casimirs().size()));
    r.members.resize(std::size_t(m));
    const auto typical = options.x_typical ? options.x_typical : typical_state(X0);
    if (!typical) {  // no finite row: nothing to build, every row ends non_finite_start
        for (Eigen::Index i = 0; i < m; ++i) end_non_finite_start(X0, i, r);
        return r;
    }
    r.x_typical = *typical;
    const NewtonStepper prototype = scheme.stepper(dt, *typical);
    const RunLoop loop(scheme);
    const std::size_t N = steps_to_reach(t_end, dt);
    const std::size_t chunk = options.chunk ? options.chunk : std::max<std::size_t>(1, std::size_t(m) / (8 * r.threads));
    tbb::enumerable_thread_specific<Worker> workers([&] { return Worker(prototype, loop); });
    std::optional<tbb::global_control> allow;  // more workers than cores when asked (TBB's limit is the cores)
    if (r.threads > std::size_t(tbb::info::default_concurrency()))
        allow.emplace(tbb::global_control::max_allowed_parallelism, r.threads);
    tbb::task_arena arena(int(r.threads));
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, std::size_t(m), chunk),
                          [&](const tbb::blocked_range<std::size_t>& range) {
                              run_chunk(workers.local(), X0, N, dt, range.begin(), range.end(), r);
                          },
                          tbb::simple_partitioner());
    });
    return r;
}

}  // namespace pgi
