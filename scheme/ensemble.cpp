#include "scheme/ensemble.hpp"

#include "scheme/input.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/detail/trajectory_runner.hpp"
#include "poisson/batch_step.hpp"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <iterator>
#include <cmath>
#include <limits>

namespace pgi {

TrajectoryStatus status_of(StepStatus s) {
    switch (s) {  // every StepStatus (no default: a new one is a compiler warning here)
        case StepStatus::ok:
            return TrajectoryStatus::ok;
        case StepStatus::newton_not_converged:
            return TrajectoryStatus::newton_not_converged;
        case StepStatus::non_finite:
            return TrajectoryStatus::non_finite;
        case StepStatus::truncation_above_bound:
            return TrajectoryStatus::truncation_above_bound;
        case StepStatus::ill_conditioned:
            return TrajectoryStatus::ill_conditioned;
    }
    throw std::logic_error("status_of: unknown StepStatus");
}

std::string to_string(TrajectoryStatus s) {
    switch (s) {
        case TrajectoryStatus::ok:
            return "ok";
        case TrajectoryStatus::newton_not_converged:
            return "newton_not_converged";
        case TrajectoryStatus::non_finite:
            return "non_finite";
        case TrajectoryStatus::truncation_above_bound:
            return "truncation_above_bound";
        case TrajectoryStatus::ill_conditioned:
            return "ill_conditioned";
        case TrajectoryStatus::non_finite_start:
            return "non_finite_start";
    }
    return "?";
}

RunPlan plan_ensemble(const Scheme& scheme, std::size_t m, double dt, double t_end, const RunLimits& limits,
                      const TrajectoryOptions& record) {
    return plan_run(trajectory_request(scheme, dt, t_end, record, std::max<std::size_t>(1, m)), limits);
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

// Where a trajectory's rows go when the ensemble records every `every`-th state and the last (lanes and single
// steppers alike): its slice of EnsembleResult::record_x, as its single run's observer records them.
struct RowSink {
    std::size_t every = 0, dim = 0, records = 0;
    double* out = nullptr;  // record_x's data
    std::size_t rows = 0;   // recorded so far by the trajectory on it
    double* next = nullptr;

    void begin(Eigen::Index i) {
        rows = 0;
        if (every) next = out + std::size_t(i) * records * dim;
    }
    // the state after step n (N the last)
    void observe(std::size_t n, std::size_t N, const Eigen::VectorXd& x) {
        if (!records_step(n, n == N, every)) return;
        std::copy(x.data(), x.data() + dim, next);
        next += dim, ++rows;
    }
};

// What one worker owns: its copy of the compiled step (reset from the prototype before each trajectory, so
// a trajectory starts from the state a single run's fresh stepper has), of the run loop (its compiled
// invariants and scratch), and the state; with batches, the batch step and one run per lane.
struct LaneRun;
struct Worker {
    const NewtonStepper* prototype;
    NewtonStepper stepper;
    RunLoop loop;
    Eigen::VectorXd x;
    std::optional<BatchStepper> batch;
    std::vector<LaneRun> lanes;
    std::vector<double> X, increments;        // the batch's states and increments, structure of arrays
    std::vector<double> values, map_scratch;  // the invariants at the lanes' new states (structure of arrays)
    std::vector<StepStatus> status;
    RowSink rows;  // the recording's shape (every = 0: none); each lane and run_one copy it

    Worker(const NewtonStepper& p, const RunLoop& l, std::size_t batch_lanes, const RowSink& sink);
};

// A row that is not finite: kept as it is, no step taken, its errors NaN.
void end_non_finite_start(const Eigen::Ref<const RowMatrix>& X0, Eigen::Index i, EnsembleResult& r) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.x.row(i) = X0.row(i);
    r.members[std::size_t(i)].status = TrajectoryStatus::non_finite_start;
    r.energy_error(i) = nan;
    r.casimir_error.row(i).setConstant(nan);
}

// Row i's results: the final (last observed) state x, how the run ended, the invariants' largest errors.
void record(const Eigen::VectorXd& x, const RunEnd& end, const RunLoop& loop, double residual, double dt,
            Eigen::Index i, EnsembleResult& r, std::size_t rows) {
    EnsembleMember& m = r.members[std::size_t(i)];
    m.rows = rows;
    r.x.row(i) = x.transpose();
    m.status = status_of(end.status);
    m.steps = end.steps;
    m.newton_iterations_mean = end.mean_iterations;
    m.newton_iterations_max = end.max_iterations;
    r.energy_error(i) = loop.error_max()[0];
    m.energy_warning = energy_drifted(r.energy_error(i));
    for (Eigen::Index c = 0; c < r.casimir_error.cols(); ++c)
        r.casimir_error(i, c) = loop.error_max()[std::size_t(1 + c)];
    if (!end.ok()) {
        m.failed_step = end.started ? end.steps + 1 : 0;
        m.failed_t = double(end.steps) * dt;
        m.residual = residual;
    }
}

// One trajectory: the run loop of pgi::integrate (scheme/run_loop.hpp) with an observer that keeps the rows asked
// for, if any (the loop leaves x at the last state observed).
void run_one(Worker& w, const Eigen::Ref<const RowMatrix>& X0, std::size_t N, double dt, Eigen::Index i,
             EnsembleResult& r) {
    if (!X0.row(i).allFinite()) return end_non_finite_start(X0, i, r);
    w.stepper = *w.prototype;
    w.x = X0.row(i).transpose();
    w.rows.begin(i);
    const RunEnd end = w.loop.run(w.stepper, w.x, N, [&](const RunPoint& p) {
        w.rows.observe(p.step, N, p.x);
        return false;
    });
    record(w.x, end, w.loop, w.stepper.last_residual(), dt, i, r, w.rows.rows);
}

// One trajectory of a batch, stepped by the batch: integrate_steps' TrajectoryState (the compensated sum, the
// step's statistics and status) and RunLoop::run's observation of every state, so its numbers are run_one's bit
// for bit.
struct LaneRun {
    Eigen::Index row = -1;
    RunLoop loop;
    TrajectoryState state;
    Eigen::VectorXd last;  // the last state observed
    RunEnd end;
    double residual = 0;  // the last step's Newton residual
    RowSink rows;

    LaneRun(const RunLoop& l, Eigen::Index n, const RowSink& sink) : loop(l), state(n), last(n), rows(sink) {}

    // Starts row i at x0 (finite) for N steps; false when the run ends there (N = 0, an invariant not finite).
    bool begin(Eigen::Index i, const Eigen::VectorXd& x0, std::size_t N, double prototype_residual) {
        row = i;
        state.begin(x0);
        last = x0;
        end = RunEnd{};
        residual = prototype_residual;
        loop.begin(x0);
        rows.begin(i);
        if (!loop.observe(x0, true)) return stop(StepStatus::non_finite);
        rows.observe(0, N, x0);
        end.started = true;
        return N > 0;
    }
    // After one more step that ended with status s, its Newton iterations and residual, its increment at
    // inc[v stride]: false when the run ends (a failed step, a non-finite state); else observed() follows.
    bool stepped(StepStatus s, int step_iterations, double step_residual, const double* inc, std::size_t stride) {
        residual = step_residual;
        if (!state.stepped(s, step_iterations, inc, stride)) return stop(state.status());
        end.mean_iterations = state.mean_iterations();
        return true;
    }
    // The invariants at the new state at values[i stride]: false when the run ends (step N, an invariant not finite).
    bool observed(const double* values, std::size_t stride, std::size_t N) {
        if (!loop.observe_values(values, stride, false)) return stop(StepStatus::non_finite);
        end.max_iterations = std::max(end.max_iterations, state.last_iterations());
        end.steps = state.steps();
        last = state.x();
        rows.observe(end.steps, N, last);
        return state.steps() < N;
    }
    bool stop(StepStatus s) {
        end.status = s;
        end.mean_iterations = state.mean_iterations();
        state.x() = last;
        return false;
    }
    const Eigen::VectorXd& x() const { return state.x(); }
};

Worker::Worker(const NewtonStepper& p, const RunLoop& l, std::size_t batch_lanes, const RowSink& sink)
    : prototype(&p), stepper(p), loop(l), x(Eigen::Index(p.dim())), rows(sink) {
    if (batch_lanes <= 1) return;
    batch.emplace(p, batch_lanes);
    lanes.assign(batch_lanes, LaneRun(l, Eigen::Index(p.dim()), sink));
    X.resize(batch_lanes * p.dim());
    increments.resize(X.size());
    values.resize(batch_lanes * l.invariants().num_outputs());
    status.resize(batch_lanes);
}

// The trajectories begin..end-1 in a batch: each free lane takes the next row, the batch steps every busy
// lane at once (packed: X holds the busy lanes only), a lane whose run ends is recorded and freed.
void run_batched(Worker& w, const Eigen::Ref<const RowMatrix>& X0, std::size_t N, double dt, std::size_t begin,
                 std::size_t end, EnsembleResult& r) {
    const std::size_t n = w.prototype->dim();
    std::vector<LaneRun*> busy;  // (at most lanes() pointers: reserved once per chunk)
    busy.reserve(w.lanes.size());
    std::vector<LaneRun*> free;
    free.reserve(w.lanes.size());
    for (auto& lane : w.lanes) free.push_back(&lane);
    std::size_t next = begin;
    const auto fill = [&] {
        while (!free.empty() && next < end) {
            const auto i = Eigen::Index(next++);
            if (!X0.row(i).allFinite()) {
                end_non_finite_start(X0, i, r);
                continue;
            }
            LaneRun* lane = free.back();
            w.x = X0.row(i).transpose();
            if (lane->begin(i, w.x, N, w.prototype->last_residual())) {
                free.pop_back();
                busy.push_back(lane);
            } else {
                record(lane->x(), lane->end, lane->loop, lane->residual, dt, i, r, lane->rows.rows);
            }
        }
    };
    fill();
    while (!busy.empty()) {
        const std::size_t m = busy.size();
        for (std::size_t j = 0; j < m; ++j)
            for (std::size_t v = 0; v < n; ++v) w.X[v * m + j] = busy[j]->x()[Eigen::Index(v)];
        w.batch->step(w.X.data(), m, dt, w.increments.data(), w.status.data());
        // the lanes that stepped, then the invariants at their new states at once (eval_batch: eval's bits); a
        // lane whose run ends is recorded and freed
        std::size_t kept = 0;
        const auto keep = [&](LaneRun* lane, bool going) {
            if (going) {
                busy[kept++] = lane;
                return;
            }
            record(lane->x(), lane->end, lane->loop, lane->residual, dt, lane->row, r, lane->rows.rows);
            free.push_back(lane);
        };
        for (std::size_t j = 0; j < m; ++j)
            keep(busy[j], busy[j]->stepped(w.status[j], w.batch->last_iterations(j), w.batch->last_residual(j),
                                           w.increments.data() + j, m));
        const std::size_t stepped = kept;
        for (std::size_t j = 0; j < stepped; ++j)
            for (std::size_t v = 0; v < n; ++v) w.X[v * stepped + j] = busy[j]->x()[Eigen::Index(v)];
        w.loop.invariants().eval_batch(w.X.data(), w.values.data(), stepped, w.map_scratch);
        kept = 0;
        for (std::size_t j = 0; j < stepped; ++j) keep(busy[j], busy[j]->observed(w.values.data() + j, stepped, N));
        busy.resize(kept);
        fill();
    }
}

// The one place that advances a chunk of trajectories.
void run_chunk(Worker& w, const Eigen::Ref<const RowMatrix>& X0, std::size_t N, double dt, std::size_t begin,
               std::size_t end, EnsembleResult& r) {
    if (w.batch) return run_batched(w, X0, N, dt, begin, end, r);
    for (std::size_t i = begin; i < end; ++i) run_one(w, X0, N, dt, Eigen::Index(i), r);
}

// The times of a recording run's rows: t_eval, or the steps every `every` and the last (none at every = 0).
std::vector<double> record_times(const TrajectoryOptions& record, std::size_t N, double dt) {
    if (!record.t_eval.empty()) return record.t_eval;
    std::vector<double> t;
    for_each_recorded_step(N, record.every, [&](std::size_t n) { t.push_back(double(n) * dt); });
    return t;
}

// Row i's results from its run tr (its single run's): the final state (head: the coordinates; the parameters are
// constant), how it ended, its errors, its rows, crossings and tangent map into their slices.
void record_run(Trajectory&& tr, const Eigen::Ref<const RowMatrix>& X0, Eigen::Index i, EnsembleResult& r,
                std::vector<EnsembleCrossing>& crossings) {
    const std::size_t n = tr.dim, rows = tr.t.size();
    EnsembleMember& m = r.members[std::size_t(i)];
    r.x.row(i) = X0.row(i);
    r.x.row(i).head(Eigen::Index(n)) = Eigen::Map<const Eigen::RowVectorXd>(tr.x_last.data(), Eigen::Index(n));
    m.status = status_of(tr.status);
    m.steps = tr.steps;
    m.failed_step = tr.failed_step;
    m.failed_t = tr.failed_t;
    m.residual = tr.failed_residual;
    m.newton_iterations_mean = tr.newton_iterations_mean;
    m.newton_iterations_max = tr.newton_iterations_max;
    m.energy_warning = tr.energy_warning;
    m.terminal_event = tr.terminal_event;
    m.rows = rows;
    r.energy_error(i) = tr.energy_error_max;
    for (Eigen::Index c = 0; c < r.casimir_error.cols(); ++c)
        r.casimir_error(i, c) = tr.casimir_error_max[std::size_t(c)];
    std::copy(tr.x.begin(), tr.x.end(), r.record_x.begin() + long(std::size_t(i) * r.record_t.size() * n));
    std::copy(tr.jacobian.begin(), tr.jacobian.end(), r.jacobian.begin() + long(std::size_t(i) * n * n));
    for (Crossing& c : tr.crossings) {
        c.x.conservativeResize(Eigen::Index(n));
        crossings.push_back({std::size_t(i), std::move(c)});
    }
}

// A recording run's arrays, shaped for m trajectories of n coordinates and filled with NaN (a trajectory's rows
// replace them).
void prepare_records(const TrajectoryOptions& record, const RunPlan& plan, double dt, std::size_t m, std::size_t n,
                     EnsembleResult& r) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.record_t = record_times(record, plan.steps, dt);
    r.record_x.assign(m * r.record_t.size() * n, nan);
    if (record.tangent) r.jacobian.assign(m * n * n, nan);
}

// The ensemble of a recording run: each thread runs its rows through its copy of one TrajectoryRunner (the single
// run's code, so each member is its single run bit for bit).
void run_recording(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, const RunPlan& plan,
                   const EnsembleOptions& options, const Eigen::VectorXd& typical, EnsembleResult& r) {
    const std::size_t m = std::size_t(X0.rows());
    std::vector<std::vector<EnsembleCrossing>> crossings(m);
    const TrajectoryRunner prototype(scheme, dt, plan, options.record, typical, options.control.cancel);
    tbb::enumerable_thread_specific<TrajectoryRunner> runners(prototype);
    const std::size_t chunk = options.chunk ? options.chunk : std::max<std::size_t>(1, m / (8 * r.threads));
    tbb::task_arena arena(int(r.threads));
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, m, chunk),
            [&](const tbb::blocked_range<std::size_t>& range) {
                TrajectoryRunner& runner = runners.local();
                for (std::size_t i = range.begin(); i < range.end(); ++i) {
                    const auto row = Eigen::Index(i);
                    if (!X0.row(row).allFinite()) {
                        end_non_finite_start(X0, row, r);
                        continue;
                    }
                    record_run(runner.run(X0.row(row).transpose()), X0, row, r, crossings[i]);
                }
            },
            tbb::simple_partitioner());
    });
    for (auto& c : crossings) std::move(c.begin(), c.end(), std::back_inserter(r.crossings));
}

// Lanes per batch when the options leave it open: 16 (two of CompiledMap's 8-lane blocks, measured best on
// the rigid body, tools/bench/bench_ensemble.py), and none from 40 coordinates on (a lattice's step is its
// sparse Newton, not the compiled polynomials, and each lane holds a copy of the step).
std::size_t default_batch(std::size_t n) {
    return n < 40 ? 16 : 1;
}
// Each lane holds a copy of the step: bounded.
constexpr std::size_t max_batch = 1024;

// Everything a surface could get wrong, checked before any work: the run (plan_run), X0's shape, the options.
RunPlan check_arguments(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                        const EnsembleOptions& options) {
    const auto n = Eigen::Index(scheme.phase_space().dim());
    if (X0.cols() != n)
        throw InputError(
            "X0", "must have " + std::to_string(n) + " columns (one per coordinate), got " + std::to_string(X0.cols()));
    const RunPlan plan =
        plan_ensemble(scheme, std::size_t(X0.rows()), dt, t_end, options.control.limits, options.record);
    const std::size_t most = std::max<std::size_t>(256, 4 * std::size_t(tbb::info::default_concurrency()));
    if (options.threads > most)
        throw InputError("threads", std::to_string(options.threads) + " is above the limit of " + std::to_string(most) +
                                        " (4 per core, at least 256)");
    if (options.batch > max_batch)
        throw InputError("batch", std::to_string(options.batch) + " is above the limit of " +
                                      std::to_string(max_batch) + " trajectories stepped together");
    if (const auto& xt = options.x_typical) {
        if (xt->size() != n)
            throw InputError("x_typical",
                             "must have " + std::to_string(n) + " values, got " + std::to_string(xt->size()));
        if (!xt->allFinite()) throw InputError("x_typical", "must be finite");
    }
    return plan;
}

// The ensemble of the extended states X0 (m x phase_space().dim(): the coordinates, then the parameter values).
EnsembleResult integrate_extended(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                                  const EnsembleOptions& options) {
    const RunPlan plan = check_arguments(scheme, X0, dt, t_end, options);
    const Eigen::Index m = X0.rows(), n = X0.cols();
    EnsembleResult r;
    r.threads = options.threads ? options.threads : std::size_t(tbb::info::default_concurrency());
    r.x = RowMatrix::Zero(m, n);
    r.energy_error = Eigen::VectorXd::Zero(m);
    r.casimir_error = RowMatrix::Zero(m, Eigen::Index(scheme.casimirs().size()));
    r.members.resize(std::size_t(m));
    if (options.record.records()) prepare_records(options.record, plan, dt, std::size_t(m), scheme.dim(), r);
    const auto typical = options.x_typical ? options.x_typical : typical_state(X0);
    if (!typical) {  // no finite row: nothing to build, every row ends non_finite_start
        for (Eigen::Index i = 0; i < m; ++i) end_non_finite_start(X0, i, r);
        return r;
    }
    r.x_typical = *typical;
    std::optional<tbb::global_control> allow;  // more workers than cores when asked (TBB's limit is the cores)
    if (r.threads > std::size_t(tbb::info::default_concurrency()))
        allow.emplace(tbb::global_control::max_allowed_parallelism, r.threads);
    const TrajectoryOptions& record = options.record;
    if (record.tangent || !record.events.specs.empty() || !record.t_eval.empty()) {  // else rows on lanes, if any
        run_recording(scheme, X0, dt, plan, options, *typical, r);
        return r;
    }
    const NewtonStepper prototype = scheme.stepper(dt, *typical);
    RunLoop loop(scheme);
    loop.set_cancel(options.control.cancel);
    const std::size_t N = plan.steps;
    const std::size_t batch = options.batch ? options.batch : default_batch(std::size_t(n));
    const std::size_t chunk = options.chunk ? options.chunk : std::max(batch, std::size_t(m) / (8 * r.threads));
    const std::size_t lanes = std::min(batch, chunk);
    RowSink sink;
    sink.every = record.every, sink.dim = scheme.dim(), sink.records = r.record_t.size(), sink.out = r.record_x.data();
    tbb::enumerable_thread_specific<Worker> workers([&] { return Worker(prototype, loop, lanes, sink); });
    tbb::task_arena arena(int(r.threads));
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, std::size_t(m), chunk),
            [&](const tbb::blocked_range<std::size_t>& range) {
                run_chunk(workers.local(), X0, N, dt, range.begin(), range.end(), r);
            },
            tbb::simple_partitioner());
    });
    return r;
}

}  // namespace

EnsembleResult integrate_ensemble(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X0, double dt, double t_end,
                                  const EnsembleOptions& options) {
    if (scheme.parameters().empty() && options.parameters.empty())
        return integrate_extended(scheme, X0, dt, t_end, options);
    const auto n = Eigen::Index(scheme.dim());
    if (X0.cols() != n)
        throw InputError(
            "X0", "must have " + std::to_string(n) + " columns (one per coordinate), got " + std::to_string(X0.cols()));
    if (options.x_typical && options.x_typical->size() != n)
        throw InputError("x_typical", "must have " + std::to_string(n) + " values, got " +
                                          std::to_string(options.x_typical->size()));
    const RowMatrix P = scheme.parameter_rows(options.parameters, std::size_t(X0.rows()));
    EnsembleOptions extended = options;
    // the step is built at the typical coordinates with each parameter at its value of largest magnitude over the rows
    // (the build's choices are made for the largest terms; at the largest row's values, a row whose coordinates were
    // larger and another whose parameter was larger could not both be served: one ended truncation_above_bound)
    if (const auto typical = options.x_typical ? options.x_typical : typical_state(X0)) {
        Eigen::RowVectorXd largest(P.cols());
        for (Eigen::Index c = 0; c < P.cols(); ++c) {
            Eigen::Index row = 0;
            P.col(c).cwiseAbs().maxCoeff(&row);
            largest[c] = P(row, c);
        }
        extended.x_typical = scheme.extended_states(typical->transpose(), largest).row(0).transpose();
    }
    EnsembleResult r = integrate_extended(scheme, scheme.extended_states(X0, P), dt, t_end, extended);
    r.x = r.x.leftCols(n).eval();
    if (r.x_typical.size()) r.x_typical = r.x_typical.head(n).eval();
    return r;
}

}  // namespace pgi
