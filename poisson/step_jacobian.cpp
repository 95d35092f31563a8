#include "poisson/step_jacobian.hpp"

#include "poisson/detail/newton_internals.hpp"

namespace pgi {

namespace {

// out = I + D A^{-1}, from A^T X^T = D^T by partial-pivoting LU of A^T, at a fixed size N (on the stack, unrolled) or
// dynamic (N = Eigen::Dynamic).
template <int N>
void one_plus_right_divide(const Eigen::MatrixXd& D, const Eigen::MatrixXd& A, Eigen::MatrixXd& out) {
    using M = Eigen::Matrix<double, N, N>;
    const M at = A.transpose(), dt = D.transpose();
    const Eigen::PartialPivLU<M> lu(at);
    M x = lu.solve(dt).transpose();
    x.diagonal().array() += 1.0;
    out = x;
}

void one_plus_right_divide_any(const Eigen::MatrixXd& D, const Eigen::MatrixXd& A, Eigen::MatrixXd& out) {
    switch (A.rows()) {
        case 2:
            return one_plus_right_divide<2>(D, A, out);
        case 3:
            return one_plus_right_divide<3>(D, A, out);
        case 4:
            return one_plus_right_divide<4>(D, A, out);
        case 6:
            return one_plus_right_divide<6>(D, A, out);
        default:
            return one_plus_right_divide<Eigen::Dynamic>(D, A, out);
    }
}

}  // namespace

// NOTE: the Newton iterations' own factors are of an earlier iterate (and, on small dense problems, of a Hessian that
// neglects the S_j below round-off for Newton's convergence, compile_gradient): exact to round-off needs A anew at
// the accepted base point with the whole Hessian, one evaluation of the Newton system and one small LU.
bool NewtonStepper::last_step_jacobian(Eigen::MatrixXd& jacobian) {
    const Eigen::Index n = xb_.size();
    // p = grad S_dt(xb), Hess S_dt(xb) on its pattern (whole: the full Hessian's map when the Newton matrix's is not)
    if (in_->gradient_.full_hessian.empty()) {
        in_->gradient_.with_hessian.eval(xb_.data(), step_dt_, gh_.data());
        p_ = gh_.head(n);
    } else {
        in_->gradient_.gradient.eval(xb_.data(), step_dt_, p_.data());
        in_->gradient_.full_hessian.eval(xb_.data(), step_dt_, gh_.data() + n);
    }
    expand_hessian(in_->gradient_, gh_.data() + n, hessian_.data());
    in_->gradient_.hessian.scatter(hessian_.data(), hess_);
    // the realisation's dense derivatives at (xb, p): a tangent map is dense anyway (sized here on the sparse path)
    if (in_->v_.alpha.size() != n) in_->v_ = RealisationValues(std::size_t(n));
    in_->realisation_.eval(xb_, p_, in_->v_);
    // A = alpha_x + alpha_p Hess S_dt;  D = delta_x + delta_p Hess S_dt;  jacobian = I + D A^{-1}
    J_ = in_->v_.alpha_x;
    J_.noalias() += in_->v_.alpha_p * hess_;
    D_ = in_->v_.delta_x;
    D_.noalias() += in_->v_.delta_p * hess_;
    one_plus_right_divide_any(D_, J_, jacobian);
    return jacobian.allFinite();
}

StepWithJacobian step_with_jacobian(NewtonStepper& stepper, const Eigen::VectorXd& x, double dt) {
    StepWithJacobian r;
    Eigen::VectorXd increment(x.size());
    r.status = stepper.step(x, dt, increment);
    if (r.status != StepStatus::ok) return r;
    r.x_new = x + increment;
    if (!stepper.last_step_jacobian(r.jacobian)) r.status = StepStatus::non_finite;
    return r;
}

TangentProduct::TangentProduct(Eigen::Index n)
    : step_(Eigen::MatrixXd::Identity(n, n)), product_(Eigen::MatrixXd::Identity(n, n)), scratch_(n, n) {}

bool TangentProduct::after_step(NewtonStepper& stepper) {
    const bool ok = stepper.last_step_jacobian(step_);
    scratch_.noalias() = step_ * product_;
    product_.swap(scratch_);
    return ok;
}

}  // namespace pgi
