#pragma once
// The tangent map of the implicit step (docs/math.md 6, "The step's tangent map"): the step solves
// alpha(xb, grad S_dt(xb)) = x for xb and returns beta(xb, grad S_dt(xb)); differentiating, dx = A dxb and
// dx_new = B dxb with A = alpha_x + alpha_p Hess S_dt (the Newton matrix) and B = beta_x + beta_p Hess S_dt, so
// the step's Jacobian is B A^{-1} = I + (delta_x + delta_p Hess S_dt) A^{-1}, exact to round-off at the accepted
// base point (NewtonStepper::last_step_jacobian), with no finite differences and no derivative of the iterations.
#include "poisson/newton_step.hpp"

#include <Eigen/Dense>

namespace pgi {

/// One step with its derivative: status, and when ok the new state x_new and jacobian = d x_new / d x (n x n).
struct StepWithJacobian {
    StepStatus status = StepStatus::ok;
    Eigen::VectorXd x_new;
    Eigen::MatrixXd jacobian;
};

/// Steps stepper from x by dt and sets the step's Jacobian there. The status is the step's (non_finite also when
/// the Newton matrix at the accepted base point is singular). Requires x of stepper.dim() values.
StepWithJacobian step_with_jacobian(NewtonStepper& stepper, const Eigen::VectorXd& x, double dt);

/// The derivative of a run's map, the product J_N ... J_1 of its steps' Jacobians (the variational equation of the
/// discrete map), accumulated after each step as the run takes it: an observer's policy of the one run loop.
class TangentProduct {
public:
    /// The identity of n x n (no step yet).
    explicit TangentProduct(Eigen::Index n);
    /// After an ok step of stepper: last() = that step's Jacobian, product() = last() product(). False when the
    /// Newton matrix was singular (both then not finite).
    bool after_step(NewtonStepper& stepper);
    const Eigen::MatrixXd& product() const { return product_; }
    const Eigen::MatrixXd& last() const { return step_; }

private:
    Eigen::MatrixXd step_, product_, scratch_;
};

}  // namespace pgi
