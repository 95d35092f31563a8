#pragma once
// One trajectory's run, set up once and run from many starts: what pgi::integrate runs once and each thread of a
// recording ensemble runs for its rows (scheme/ensemble.hpp), so a member's rows, crossings and tangent map are its
// single run's bit for bit.
#include "poisson/events.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/trajectory.hpp"

#include <Eigen/Dense>

#include <optional>

namespace pgi {

/// One trajectory's run set up once (the step compiled at x_typical, the events and the invariants compiled) and
/// run from any number of starts, each exactly as pgi::integrate runs it (a fresh copy of the step each time). One
/// copy per thread runs an ensemble whose members are their single runs bit for bit.
class TrajectoryRunner {
public:
    /// For runs of plan.steps steps (plan_run of trajectory_request: checked) of dt. x_typical: an extended state
    /// (the coordinates, then the parameter values), finite. Throws, before the step is built, what EventSet::build
    /// throws for a bad event.
    TrajectoryRunner(const Scheme& scheme, double dt, const RunPlan& plan, const TrajectoryOptions& options,
                     const Eigen::VectorXd& x_typical, const RunCancel* cancel = nullptr);
    /// The run from x0 (an extended state, finite): the rows, crossings and tangent map its options ask for.
    Trajectory run(const Eigen::VectorXd& x0);
    const NewtonStepper& stepper() const { return prototype_; }

private:
    const Scheme* scheme_;
    TrajectoryOptions options_;
    std::size_t steps_;
    std::optional<EventSet> events_;
    NewtonStepper prototype_, stepper_;
    std::optional<EventDetector> detector_prototype_, detector_;
    RunLoop loop_;
};

}  // namespace pgi
