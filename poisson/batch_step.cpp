#include "poisson/batch_step.hpp"

#include <algorithm>
#include <stdexcept>

namespace pgi {

BatchStepper::BatchStepper(const NewtonStepper& prototype, std::size_t lanes)
    : lanes_(std::max<std::size_t>(lanes, 1), prototype), x_(Eigen::Index(prototype.dim())), increment_(x_) {
    if (lanes == 0) throw std::invalid_argument("BatchStepper: at least one lane");
}

void BatchStepper::step(const double* X, std::size_t m, double dt, double* increments, StepStatus* status) {
    if (m > lanes_.size()) throw std::invalid_argument("BatchStepper::step: more states than lanes");
    const NewtonStepper& maps = lanes_.front();
    const std::size_t n = dim(), width = maps.with_hessian().width();
    if (xb_.size() < n * m) xb_.resize(n * m);
    if (gh_.size() < width * m) gh_.resize(width * m);
    maps.predictor().eval_batch(X, dt, xb_.data(), m, scratch_);
    maps.with_hessian().eval_batch(xb_.data(), dt, gh_.data(), m, scratch_);
    for (std::size_t j = 0; j < m; ++j) {
        for (std::size_t v = 0; v < n; ++v) x_[Eigen::Index(v)] = X[v * m + j];
        status[j] = lanes_[j].step_predicted(x_, dt, xb_.data() + j, gh_.data() + j, m, increment_);
        for (std::size_t v = 0; v < n; ++v) increments[v * m + j] = increment_[Eigen::Index(v)];
    }
}

}  // namespace pgi
