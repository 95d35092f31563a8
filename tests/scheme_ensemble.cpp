// Ensembles: every trajectory equals its single run bit for bit, whatever the threads and chunks; bad
// input refused before any work; a NaN row and a failing trajectory end alone with their status.
#include "scheme/ensemble.hpp"
#include "scheme/trajectory.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <span>

using namespace pgi;

namespace {

// m states around the rigid body's x0 with norms from 0.5 to 2 (deterministic, no two equal)
RowMatrix rigid_body_states(Eigen::Index m) {
    RowMatrix X(m, 3);
    for (Eigen::Index i = 0; i < m; ++i) {
        const double a = 0.37 * double(i), s = 0.5 + 1.5 * double(i) / double(m);
        X.row(i) << s * std::cos(a) * 0.8, s * std::sin(a) * 0.6, s * (0.3 + 0.05 * double(i % 5));
    }
    return X;
}

EnsembleOptions with(std::size_t threads, std::size_t chunk = 0, std::optional<Eigen::VectorXd> typical = std::nullopt,
                     std::size_t batch = 0) {
    EnsembleOptions o;
    o.threads = threads;
    o.chunk = chunk;
    o.batch = batch;
    o.x_typical = std::move(typical);
    return o;
}

// the ensemble's row i against its single run with the ensemble's x_typical: every number equal
void require_single_run(const Scheme& scheme, const RowMatrix& X0, const EnsembleResult& r, Eigen::Index i, double dt,
                        double t_end) {
    CAPTURE(i);
    const auto N = std::size_t(steps_to_reach(t_end, dt));
    const Trajectory tr = integrate(scheme, X0.row(i).transpose(), dt, t_end, N, r.x_typical);
    const EnsembleMember& m = r.members[std::size_t(i)];
    CHECK(m.status == status_of(tr.status));
    CHECK(m.steps == tr.steps);
    const Eigen::Index last = Eigen::Index(tr.t.size()) - 1;
    for (Eigen::Index j = 0; j < 3; ++j) CHECK(r.x(i, j) == tr.x[std::size_t(last * 3 + j)]);
    CHECK(r.energy_error(i) == tr.energy_error_max);
    CHECK(r.casimir_error(i, 0) == tr.casimir_error_max[0]);
    CHECK(m.newton_iterations_mean == tr.newton_iterations_mean);
    CHECK(m.newton_iterations_max == tr.newton_iterations_max);
    CHECK(m.failed_step == tr.failed_step);
    CHECK(m.energy_warning == tr.energy_warning);
    if (tr.status != StepStatus::ok) CHECK(m.residual == tr.failed_residual);
}

}  // namespace

TEST_CASE("Ensemble: each trajectory equals its single run bit for bit, whatever the threads, chunks and batches") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    const RowMatrix X0 = rigid_body_states(13);
    const double dt = 0.1, t_end = 5;
    const EnsembleResult one = integrate_ensemble(scheme, X0, dt, t_end, with(1, 13));
    Eigen::Index largest = 0;  // x_typical: the row of largest norm
    X0.rowwise().squaredNorm().maxCoeff(&largest);
    CHECK(one.x_typical == Eigen::VectorXd(X0.row(largest).transpose()));
    for (Eigen::Index i = 0; i < X0.rows(); ++i) require_single_run(scheme, X0, one, i, dt, t_end);
    for (std::size_t threads : {1, 2, 3})
        for (std::size_t chunk : {1, 4, 0})
            for (std::size_t batch : {1, 3, 16}) {
                CAPTURE(threads);
                CAPTURE(chunk);
                CAPTURE(batch);
                const EnsembleResult r =
                    integrate_ensemble(scheme, X0, dt, t_end, with(threads, chunk, std::nullopt, batch));
                CHECK(r.threads == threads);
                CHECK(r.x == one.x);
                CHECK(r.energy_error == one.energy_error);
                CHECK(r.casimir_error == one.casimir_error);
                for (std::size_t i = 0; i < r.members.size(); ++i) {
                    CHECK(r.members[i].steps == one.members[i].steps);
                    CHECK(r.members[i].newton_iterations_mean == one.members[i].newton_iterations_mean);
                    CHECK(r.members[i].newton_iterations_max == one.members[i].newton_iterations_max);
                }
            }
    // the steps moved the states, and the Casimir is kept to round-off
    CHECK((one.x - X0).cwiseAbs().maxCoeff() > 0.1);
    CHECK(one.casimir_error.maxCoeff() < 1e-14);
}

namespace {

// what a recording ensemble keeps of row i equals its single run with the same options, bit for bit
void require_recorded_run(const Scheme& scheme, const RowMatrix& X0, const EnsembleResult& r, Eigen::Index i, double dt,
                          double t_end, const TrajectoryOptions& record) {
    CAPTURE(i);
    const std::size_t n = scheme.dim(), records = r.record_t.size();
    const Trajectory tr = integrate(scheme, X0.row(i).transpose(), dt, t_end, std::max<std::size_t>(1, record.every),
                                    r.x_typical, record.events, {}, {}, record.tangent, record.t_eval);
    const EnsembleMember& m = r.members[std::size_t(i)];
    CHECK(m.status == status_of(tr.status));
    CHECK(m.terminal_event == tr.terminal_event);
    CHECK(m.steps == tr.steps);
    for (std::size_t j = 0; j < n; ++j) CHECK(r.x(i, Eigen::Index(j)) == tr.x_last[j]);
    CHECK(r.energy_error(i) == tr.energy_error_max);
    if (record.every > 0 || !record.t_eval.empty()) {
        REQUIRE(m.rows == tr.t.size());
        const auto first = r.record_x.begin() + long(std::size_t(i) * records * n);
        CHECK(std::equal(tr.x.begin(), tr.x.end(), first));
        CHECK(
            std::all_of(first + long(tr.x.size()), first + long(records * n), [](double v) { return std::isnan(v); }));
        for (std::size_t k = 0; k + (tr.terminal_event ? 1 : 0) < tr.t.size(); ++k) CHECK(r.record_t[k] == tr.t[k]);
    }
    std::vector<const Crossing*> mine;
    for (const EnsembleCrossing& c : r.crossings)
        if (c.row == std::size_t(i)) mine.push_back(&c.crossing);
    REQUIRE(mine.size() == tr.crossings.size());
    for (std::size_t k = 0; k < mine.size(); ++k) {
        CHECK(mine[k]->t == tr.crossings[k].t);
        CHECK(mine[k]->event == tr.crossings[k].event);
        CHECK(mine[k]->x == tr.crossings[k].x.head(Eigen::Index(n)));
    }
    if (record.tangent)
        CHECK(std::equal(tr.jacobian.begin(), tr.jacobian.end(), r.jacobian.begin() + long(std::size_t(i) * n * n)));
}

}  // namespace

TEST_CASE("Ensemble: recorded rows, crossings and tangent maps are each trajectory's single run's bit for bit") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    RowMatrix X0 = rigid_body_states(9);
    X0(4, 1) = std::numeric_limits<double>::quiet_NaN();  // a row that is not finite: NaN rows, no crossing
    const double dt = 0.1, t_end = 3.05;                  // 31 steps: every 7 records 0, 7, ..., 28 and 31
    std::vector<TrajectoryOptions> asked(4);
    asked[0].every = 7;
    asked[1].every = 0, asked[1].t_eval = {0, 0.05, 1.0, 2.37, 3.05};
    asked[2].every = 5, asked[2].events.specs = {{"x2", 0, false}}, asked[2].tangent = true;
    asked[3].every = 4, asked[3].events.specs = {{"x2", 0, true}};  // a terminal event ends rows 1-3 only
    for (const TrajectoryOptions& record : asked) {
        std::optional<EnsembleResult> first;
        for (std::size_t threads : {1, 2})
            for (std::size_t chunk : {1, 0}) {
                EnsembleOptions o = with(threads, chunk, std::nullopt, chunk ? 1 : 3);  // one at a time, lanes
                o.record = record;
                const EnsembleResult r = integrate_ensemble(scheme, X0, dt, t_end, o);
                if (!first) {
                    first = r;
                    for (Eigen::Index i = 0; i < X0.rows(); ++i)
                        if (i != 4) require_recorded_run(scheme, X0, r, i, dt, t_end, record);
                    continue;
                }
                const auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
                CHECK(std::equal(r.x.data(), r.x.data() + r.x.size(), first->x.data(), same));
                CHECK(std::equal(r.record_x.begin(), r.record_x.end(), first->record_x.begin(), first->record_x.end(),
                                 same));
                CHECK(r.crossings.size() == first->crossings.size());
            }
        const EnsembleResult& r = *first;
        CHECK(r.members[4].status == TrajectoryStatus::non_finite_start);
        CHECK(r.members[4].rows == 0);
        if (record.every == 7) CHECK(r.record_t == std::vector<double>{0, 7 * dt, 14 * dt, 21 * dt, 28 * dt, 31 * dt});
        if (!record.t_eval.empty()) CHECK(r.record_t == record.t_eval);
        if (!record.events.specs.empty()) CHECK(!r.crossings.empty());
        if (record.tangent) CHECK(std::isnan(r.jacobian[4 * 9]));
    }
    // the terminal event stopped some trajectories before t_end, and not others
    EnsembleOptions o = with(2);
    o.record = asked[3];
    const EnsembleResult r = integrate_ensemble(scheme, X0, dt, t_end, o);
    const auto ended =
        std::count_if(r.members.begin(), r.members.end(), [](const EnsembleMember& m) { return m.terminal_event; });
    CHECK(ended > 0);
    CHECK(ended == 3);
}

TEST_CASE("Ensemble: wrong shapes and values are refused before any work") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    const RowMatrix two_columns = RowMatrix::Ones(4, 2);
    const RowMatrix X0 = rigid_body_states(4);
    CHECK_THROWS_WITH_AS(integrate_ensemble(scheme, two_columns, 0.1, 1),
                         "X0: must have 3 columns (one per coordinate), got 2", InputError);
    CHECK_THROWS_WITH_AS(integrate_ensemble(scheme, X0, 0.0, 1), "dt: must be positive and finite", InputError);
    CHECK_THROWS_WITH_AS(integrate_ensemble(scheme, X0, 0.1, -1), "t_end: must be finite and not negative", InputError);
    CHECK_THROWS_AS(integrate_ensemble(scheme, X0, 0.1, 1, with(1, 0, Eigen::VectorXd::Ones(2))), InputError);
    CHECK_THROWS_AS(integrate_ensemble(scheme, X0, 0.1, 1, with(100000)), InputError);  // bounded threads
    CHECK_THROWS_WITH_AS(integrate_ensemble(scheme, X0, 0.1, 1, with(1, 0, std::nullopt, 5000)),
                         "batch: 5000 is above the limit of 1024 trajectories stepped together", InputError);
    CHECK(scheme.stats().stepper_builds == 0);  // nothing was built
    // no rows: an empty result, still nothing built
    const EnsembleResult empty = integrate_ensemble(scheme, RowMatrix(0, 3), 0.1, 1);
    CHECK(empty.members.empty());
    CHECK(scheme.stats().stepper_builds == 0);
}

TEST_CASE("Ensemble: a NaN row ends with its status and the others finish as without it") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    RowMatrix X0 = rigid_body_states(6);
    const EnsembleResult clean = integrate_ensemble(scheme, X0, 0.1, 2, with(2));
    X0(2, 1) = std::numeric_limits<double>::quiet_NaN();
    X0(4, 0) = std::numeric_limits<double>::infinity();
    const EnsembleResult r = integrate_ensemble(scheme, X0, 0.1, 2, with(2, 0, clean.x_typical));
    for (Eigen::Index i = 0; i < 6; ++i) {
        CAPTURE(i);
        if (i == 2 || i == 4) {
            CHECK(r.members[std::size_t(i)].status == TrajectoryStatus::non_finite_start);
            CHECK(r.members[std::size_t(i)].steps == 0);
            CHECK(std::isnan(r.energy_error(i)));
            CHECK_FALSE(r.members[std::size_t(i)].energy_warning);            // not a run: its own status says why
            CHECK((i == 2 ? std::isnan(r.x(2, 1)) : std::isinf(r.x(4, 0))));  // the row as it was
        } else {
            CHECK(r.members[std::size_t(i)].status == TrajectoryStatus::ok);
            CHECK(r.x.row(i) == clean.x.row(i));
            CHECK(r.energy_error(i) == clean.energy_error(i));
        }
    }
    // every row not finite: no stepper is needed, every row says why
    const EnsembleResult all_nan = integrate_ensemble(scheme, RowMatrix::Constant(2, 3, std::nan("")), 0.1, 1);
    CHECK(all_nan.x_typical.size() == 0);
    CHECK(all_nan.members[1].status == TrajectoryStatus::non_finite_start);
}

TEST_CASE("Ensemble: a trajectory whose step fails ends alone, with the failed step, t and residual") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    RowMatrix X0 = rigid_body_states(5);
    X0.row(3) *= 1e4;  // |x| ~ 1e4: dt |x| ~ 1e3, far beyond what the step built at x_typical solves
    const Eigen::VectorXd typical = X0.row(0).transpose();
    const double dt = 0.1, t_end = 3;
    for (std::size_t batch : {1, 4}) {
        CAPTURE(batch);
        const EnsembleResult r = integrate_ensemble(scheme, X0, dt, t_end, with(2, 5, typical, batch));
        const EnsembleMember& bad = r.members[3];
        CHECK(bad.status != TrajectoryStatus::ok);
        CHECK(bad.failed_step == bad.steps + 1);
        CHECK(bad.failed_t == double(bad.steps) * dt);
        CHECK(r.x.row(3).allFinite());  // the last state reached, not the overflowed one
        for (Eigen::Index i = 0; i < 5; ++i) {
            if (i != 3) CHECK(r.members[std::size_t(i)].status == TrajectoryStatus::ok);
            require_single_run(scheme, X0, r, i, dt, t_end);
        }
    }
}

TEST_CASE(
    "Ensemble: a trajectory whose energy drifts past a tenth gets the warning its single run gets, the others not") {
    // k = 1 on the rigid body at dt = 3: every step solves its equation, but the relative energy error reaches 0.13
    // from the scene's x0 (tools_cli.cpp); a tenth of that state turns ten times slower, the error is O((dt |x|)^2)
    SceneOverrides o;
    o.order = "1";
    const Scene s = load_scene(test::scene_path("rigid_body"), o);
    const Eigen::Vector3d x0(0.4535961214255773, 0, 0.8912073600614354);
    RowMatrix X0(2, 3);
    X0.row(0) = x0.transpose();
    X0.row(1) = 0.1 * x0.transpose();
    const EnsembleResult r = integrate_ensemble(*s.scheme, X0, 3, 30, with(1));
    CHECK(r.energy_error(0) > energy_warning_from);
    CHECK(r.members[0].energy_warning);
    CHECK(r.energy_error(1) < 0.01);
    CHECK_FALSE(r.members[1].energy_warning);
    for (Eigen::Index i = 0; i < 2; ++i) require_single_run(*s.scheme, X0, r, i, 3, 30);
    CHECK(energy_drifted(std::nan("")));  // a NaN error is not a small one
}

TEST_CASE("Ensemble: a member whose first step fails ends with its single run's status, never ok") {
    // the cyclic Lotka-Volterra system through the radial realisation at dt = 2: the single run's first step fails
    SceneOverrides o;
    o.realisation = "radial";
    o.dt = "2";
    const Scene s = load_scene(test::scene_path("lotka_volterra"), o);
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), 3);
    const Trajectory tr = integrate(*s.scheme, x0, 2.0, 10.0);
    REQUIRE(tr.status != StepStatus::ok);
    RowMatrix X0(2, 3);
    X0 << x0.transpose(), x0.transpose();
    for (std::size_t batch : {1, 2}) {
        CAPTURE(batch);
        const EnsembleResult r = integrate_ensemble(*s.scheme, X0, 2.0, 10.0, with(1, 0, x0, batch));
        for (const EnsembleMember& m : r.members) {
            CHECK(m.status == status_of(tr.status));
            CHECK(to_string(m.status) != "ok");
            CHECK(m.steps == tr.steps);
            CHECK(m.failed_step == tr.failed_step);
        }
    }
}

TEST_CASE("Run budgets: steps, output and sizes are refused before any work on every run entry point") {
    const Scene s = test::bundled("rigid_body");
    const Scheme& scheme = *s.scheme;
    const Eigen::VectorXd x0 = Eigen::Vector3d(1, 0.5, 0.2);
    const RowMatrix X0 = rigid_body_states(4);
    // t_end / dt past what a size_t holds: refused, never wrapped to 0 steps
    CHECK_THROWS_AS(integrate(scheme, x0, 1e-300, 1e300), RunBudgetError);
    CHECK_THROWS_AS(integrate_ensemble(scheme, X0, 1e-20, 1e20), RunBudgetError);
    CHECK_THROWS_AS(integrate_ensemble(scheme, X0, 1e-9, 1), RunBudgetError);  // 1e9 steps
    // 1e8 steps recorded at every step: 3.7 GB of rows, above the output budget
    CHECK_THROWS_AS(integrate(scheme, x0, 1e-6, 100, 1), RunBudgetError);
    TrajectoryEvents many;
    many.specs.push_back({"x1", 0, false});
    many.samples = 1'000'000'000;
    CHECK_THROWS_AS(integrate(scheme, x0, 0.1, 1, 1, std::nullopt, many), RunBudgetError);
    CHECK(scheme.stats().stepper_builds == 0);  // nothing was built
    // a raised budget admits what the default refuses
    RunControl raised;
    raised.limits.max_output_mb = 1e5;
    RunRequest r;
    r.dt = 1e-6, r.t_end = 100, r.every = 1, r.dim = 3, r.invariants = 2;
    CHECK_THROWS_AS(plan_run(r), RunBudgetError);
    CHECK(plan_run(r, raised.limits).steps == 100'000'000);
    CHECK(plan_run(r, raised.limits).records == 100'000'001);
}

TEST_CASE("Run plan: whole steps reaching t_end, the rows a stride records") {
    RunRequest r;
    r.dt = 0.1, r.t_end = 10, r.every = 7, r.dim = 3;
    const RunPlan p = plan_run(r);
    CHECK(p.steps == 100);   // t_end / dt = 100.00000000000001 is 100 steps
    CHECK(p.records == 16);  // 0, 7, ..., 98 and the last
    r.every = 10;
    CHECK(plan_run(r).records == 11);  // 0, 10, ..., 100: the last is one of them
    r.every = 200;
    CHECK(plan_run(r).records == 2);  // the start and the last
    r.every = 0;
    CHECK(plan_run(r).records == 1);
    r.t_end = 0;
    CHECK(plan_run(r).steps == 0);
    r.t_end = 1e-12;  // a positive t_end takes one step at least
    CHECK(plan_run(r).steps == 1);
    r.dt = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH_AS(plan_run(r), "dt: must be positive and finite", InputError);
}

TEST_CASE("Recording rule: the enumerated steps are the predicate's, and recorded_steps counts them") {
    for (std::size_t N = 0; N <= 40; ++N)
        for (std::size_t every = 0; every <= 9; ++every) {
            CAPTURE(N);
            CAPTURE(every);
            std::vector<std::size_t> listed, kept;
            for_each_recorded_step(N, every, [&](std::size_t n) { listed.push_back(n); });
            for (std::size_t n = 0; n <= N; ++n)
                if (records_step(n, n == N, every)) kept.push_back(n);
            CHECK(listed == kept);
            CHECK(recorded_steps(N, every) == (every == 0 ? 1 : kept.size()));
            if (every) CHECK(kept.back() == N);  // the last state, always
        }
    CHECK(records_step(5, true, 3));  // a terminal event's state is the last
    CHECK(!records_step(5, false, 3));
    CHECK(!records_step(6, true, 0));  // every = 0 records nothing on the way
}

TEST_CASE("Run cancel: a cancelled run stops at its next step with RunInterrupted, single and ensemble") {
    const Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x0 = Eigen::Vector3d(1, 0.5, 0.2);
    RunCancel cancel;
    cancel.cancel();
    RunControl control;
    control.cancel = &cancel;
    CHECK_THROWS_AS(integrate(*s.scheme, x0, 0.1, 1e6, 1000, std::nullopt, {}, control), RunInterrupted);
    EnsembleOptions o = with(2);
    o.control = control;
    for (std::size_t batch : {1, 16}) {
        o.batch = batch;
        CHECK_THROWS_AS(integrate_ensemble(*s.scheme, rigid_body_states(64), 0.1, 1e6, o), RunInterrupted);
    }
}

TEST_CASE("Run: casimir_drift_per_step is the least-squares slope of each Casimir's signed relative error") {
    const Scene s = test::bundled("lotka_volterra");
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), 3);
    const Trajectory tr = integrate(*s.scheme, x0, 0.05, 50, 1);
    REQUIRE(tr.casimir_drift_per_step.size() == 1);
    // the fit by hand over every recorded state (every = 1: every step)
    const CompiledMap invariants = s.scheme->invariants();
    const double scale = invariant_scales(*s.scheme, std::span<const double>(x0.data(), 3))[1];
    std::vector<double> values(invariants.num_outputs());
    double c0 = 0, sn = 0, snn = 0, se = 0, sne = 0;
    const auto rows = tr.t.size();
    for (std::size_t n = 0; n < rows; ++n) {
        invariants.eval(tr.x.data() + 3 * n, values.data());
        if (n == 0) c0 = values[1];
        const double e = (values[1] - c0) / scale, k = double(n);
        sn += k, snn += k * k, se += e, sne += k * e;
    }
    const double m = double(rows), slope = (m * sne - sn * se) / (m * snn - sn * sn);
    CHECK(tr.casimir_drift_per_step[0] == doctest::Approx(slope).epsilon(1e-9));
    CHECK(std::abs(slope) < 1e-17);  // a round-off random walk over 1000 steps: no bias
}
