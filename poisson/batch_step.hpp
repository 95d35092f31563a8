#pragma once
// BatchStepper: one compiled step advancing m states together (heyoka's batch mode). On a small system most
// of a step is compiled polynomials (the predictor's series, grad and Hess S_dt: about 60% of a rigid body
// step at k = 10); the batch evaluates them for all m states at once, structure of arrays, the loops over
// the states innermost, which the compiler vectorises (CompiledMap::eval_batch). Newton then goes on lane by
// lane, each to its own acceptance (the mask: a lane that has converged is not touched by the others'
// iterations). Each lane's result is its single step's bit for bit: eval_batch gives eval's bits, and the
// rest is NewtonStepper's own code (step_predicted).
#include "poisson/newton_step.hpp"

#include <vector>

namespace pgi {

class BatchStepper {
public:
    /// Up to lanes states per step, each lane a copy of prototype (its scratch, its statistics).
    BatchStepper(const NewtonStepper& prototype, std::size_t lanes);

    std::size_t lanes() const { return lanes_.size(); }
    std::size_t dim() const { return lanes_.front().dim(); }
    /// The states X[v m + j] (coordinate v of state j, m <= lanes()) one step of dt further:
    /// increments[v m + j] = phi_dt(x_j) - x_j and status[j], each NewtonStepper::step(x_j, dt)'s bit for bit.
    /// Allocates nothing once it has stepped m states (on the dense path).
    void step(const double* X, std::size_t m, double dt, double* increments, StepStatus* status);
    /// Lane j's stepper after the last step: last_iterations(), last_residual() of state j.
    const NewtonStepper& lane(std::size_t j) const { return lanes_[j]; }

private:
    std::vector<NewtonStepper> lanes_;    // lane 0's compiled maps also serve the whole batch
    std::vector<double> xb_, gh_;         // the predicted base points, grad and Hess S_dt there (structure of arrays)
    BatchScratch scratch_;
    Eigen::VectorXd x_, increment_;
};

}  // namespace pgi
