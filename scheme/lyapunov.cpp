#include "scheme/lyapunov.hpp"

#include "poisson/step_jacobian.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/trajectory.hpp"

#include <cmath>

namespace pgi {

namespace {

// An orthonormal basis (n x (n - c)) of the tangent space of the Casimirs' level set at x: the orthogonal complement
// of their gradients, from the full Q of G = [grad C_1 ... grad C_c]'s QR. InputError when G has not rank c there.
// x is the extended state (x, w) (Scheme::extended_states); the basis is of the coordinates' space.
Eigen::MatrixXd level_set_basis(const Scheme& scheme, const Eigen::VectorXd& x) {
    const std::size_t n = scheme.dim(), c = scheme.casimirs().size();
    if (c == 0) return Eigen::MatrixXd::Identity(Eigen::Index(n), Eigen::Index(n));
    const std::vector<double> point = scheme.phase_space().point(std::span<const double>(x.data(), size_t(x.size())));
    Eigen::MatrixXd G(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(c));
    for (std::size_t j = 0; j < c; ++j)
        for (std::size_t i = 0; i < n; ++i)
            G(Eigen::Index(i), Eigen::Index(j)) = evaluate(derivative(scheme.casimirs()[j], i), point);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(G);
    const double scale = G.lpNorm<Eigen::Infinity>();
    for (Eigen::Index j = 0; j < Eigen::Index(c); ++j)
        if (!(std::abs(qr.matrixQR()(j, j)) > 1e-10 * scale))
            throw InputError("x0",
                             "the Casimirs' gradients are linearly dependent there (a singular point of the "
                             "symplectic leaves): the leaf's tangent space is not defined; start elsewhere");
    const Eigen::MatrixXd Q = qr.householderQ();
    return Q.rightCols(Eigen::Index(n - c));
}

// Benettin's frame: V (n x m) carried by each step's Jacobian and re-orthonormalised, sums_i += log |R_ii|.
class BenettinFrame {
public:
    explicit BenettinFrame(Eigen::MatrixXd V) : V_(std::move(V)), W_(V_.rows(), V_.cols()), sums_(V_.cols()) {
        sums_.setZero();
    }
    void after_step(const Eigen::MatrixXd& jacobian) {
        W_.noalias() = jacobian * V_;
        qr_.compute(W_);
        for (Eigen::Index i = 0; i < sums_.size(); ++i) sums_[i] += std::log(std::abs(qr_.matrixQR()(i, i)));
        V_ = qr_.householderQ() * Eigen::MatrixXd::Identity(V_.rows(), V_.cols());
    }
    const Eigen::VectorXd& sums() const { return sums_; }

private:
    Eigen::MatrixXd V_, W_;
    Eigen::VectorXd sums_;
    Eigen::HouseholderQR<Eigen::MatrixXd> qr_;
};

}  // namespace

LyapunovSpectrum lyapunov(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end, std::size_t every,
                          const RunControl& control, const ParameterValues& parameters) {
    const std::size_t n = scheme.dim();
    if (every == 0) throw InputError("every", "must be at least 1");
    RunRequest request;
    request.dt = dt, request.t_end = t_end, request.every = every, request.dim = n;
    request.invariants = n;  // a row: t and n exponents
    const RunPlan plan = plan_run(request, control.limits);
    if (plan.steps == 0) throw InputError("t_end", "must be positive: exponents need at least one step");
    if (static_cast<std::size_t>(x0.size()) != n || !x0.allFinite())
        throw InputError("x0", "must have " + std::to_string(n) + " finite values");
    const RowMatrix P = scheme.parameter_rows(parameters);
    scheme.require_valid();
    // the run's state is the extended one (x, w), w the parameters' values, constant: the step Jacobian's
    // coordinates' block is the Jacobian in x (w's rows are those of I)
    Eigen::VectorXd x = scheme.extended_states(x0.transpose(), P).row(0).transpose();
    BenettinFrame frame(level_set_basis(scheme, x));
    NewtonStepper stepper = scheme.stepper(dt, x);
    TangentProduct tangent(Eigen::Index(stepper.dim()));
    LyapunovSpectrum r;
    r.dim = n;
    r.leaf_dim = n - scheme.casimirs().size();
    RunLoop loop(scheme);
    loop.set_cancel(control.cancel);
    bool singular = false;
    auto observe = [&](const RunPoint& p) {
        if (p.step == 0) return false;
        if (!tangent.after_step(stepper)) return singular = true;
        frame.after_step(tangent.last().topLeftCorner(long(n), long(n)));
        if (!records_step(p.step, p.final, every)) return false;
        r.t.push_back(p.t);
        for (std::size_t i = 0; i < n; ++i)
            r.exponents.push_back(i < r.leaf_dim ? frame.sums()[Eigen::Index(i)] / p.t : 0.0);
        return false;
    };
    const RunEnd end = loop.run(stepper, x, plan.steps, observe);
    r.steps = end.steps;
    r.status = singular ? StepStatus::non_finite : end.status;
    if (!r.t.empty()) r.spectrum.assign(r.exponents.end() - long(n), r.exponents.end());
    if (r.status != StepStatus::ok) {
        r.failed_step = end.started ? end.steps + (singular ? 0 : 1) : 0;
        r.failed_t = double(r.failed_step ? r.failed_step - 1 : 0) * dt;
        r.failed_residual = stepper.last_residual();
        r.message = singular ? "step " + std::to_string(end.steps) +
                                   ": the Newton matrix at the accepted base point is singular: no tangent map there"
                             : loop.failure_message(stepper, end);
    }
    return r;
}

}  // namespace pgi
