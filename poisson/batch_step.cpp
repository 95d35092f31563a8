#include "poisson/batch_step.hpp"

#include "poisson/predictor.hpp"

#include <algorithm>
#include <stdexcept>

namespace pgi {

namespace {

template <class Pack, class Variant>
void emplace_lanes(Variant& lane, const NewtonStepper& prototype) {
    switch (prototype.lane_dimension()) {
        case 2:
            lane.template emplace<LaneStep<2, Pack>>(prototype);
            break;
        case 3:
            lane.template emplace<LaneStep<3, Pack>>(prototype);
            break;
        case 4:
            lane.template emplace<LaneStep<4, Pack>>(prototype);
            break;
        case 6:
            lane.template emplace<LaneStep<6, Pack>>(prototype);
            break;
        default:
            break;
    }
}

}  // namespace

BatchStepper::BatchStepper(const NewtonStepper& prototype, std::size_t lanes, LaneInstructions instructions)
    : capacity_(lanes), iterations_(lanes, 0), residuals_(lanes, 0.0), x_(Eigen::Index(prototype.dim())),
      increment_(x_) {
    if (lanes == 0) throw std::invalid_argument("BatchStepper: at least one lane");
    if (instructions == LaneInstructions::avx2 && !processor_has_avx2())
        throw std::invalid_argument("BatchStepper: AVX2 asked for, and this processor has none");
    if (prototype.lane_dimension() != 0) {
        const bool avx2 = instructions == LaneInstructions::avx2 ||
                          (instructions == LaneInstructions::automatic && processor_has_avx2());
        if (avx2)
            emplace_lanes<lanes::Pack4>(lane_, prototype);
        else
            emplace_lanes<lanes::Pack>(lane_, prototype);
        instructions_ = avx2 ? LaneInstructions::avx2 : LaneInstructions::sse2;
    }
    stepper_.assign(lane_.index() == 0 ? lanes : 1, prototype);
}

void BatchStepper::step(const double* X, std::size_t m, double dt, double* increments, StepStatus* status) {
    if (m > capacity_) throw std::invalid_argument("BatchStepper::step: more states than lanes");
    std::visit(
        [&](auto& lane) {
            if constexpr (std::is_same_v<std::decay_t<decltype(lane)>, std::monostate>)
                step_predicted(X, m, dt, increments, status);
            else
                step_lanes(lane, X, m, dt, increments, status);
        },
        lane_);
}

// lanes::width states at a time, the last pack padded with copies of its last state (their results dropped). The
// coordinates past N go to the lane step's passive values, their increments zero.
template <int N, class Pack>
void BatchStepper::step_lanes(LaneStep<N, Pack>& lane, const double* X, std::size_t m, double dt, double* increments,
                              StepStatus* status) {
    constexpr std::size_t W = lanes::width;
    const std::size_t n = dim();
    for (std::size_t j = 0; j < m; j += W) {
        const std::size_t count = std::min(W, m - j);
        Pack x[N], increment[N];
        StepStatus st[W];
        for (std::size_t v = 0; v < n; ++v) {
            Pack& to = v < std::size_t(N) ? x[v] : lane.passive()[v - std::size_t(N)];
            for (std::size_t w = 0; w < W; ++w) lanes::set_lane(to, w, X[v * m + j + std::min(w, count - 1)]);
            if (v < std::size_t(N))
                increment[v] = Pack{};  // (every lane written: no uninitialised bits reach the kernel)
        }
        lane.set_block(j / W);
        lane.step(stepper_.front(), x, dt, increment, st);
        for (std::size_t w = 0; w < count; ++w) {
            status[j + w] = st[w];
            iterations_[j + w] = lane.iterations(w);
            residuals_[j + w] = lane.residual(w);
            for (std::size_t v = 0; v < n; ++v)
                increments[v * m + j + w] = v < std::size_t(N) ? lanes::lane(increment[v], w) : 0.0;
        }
    }
}

// The predictor and grad and Hess S_dt at the predicted points for all states at once, then Newton state by state.
void BatchStepper::step_predicted(const double* X, std::size_t m, double dt, double* increments, StepStatus* status) {
    const NewtonStepper& maps = stepper_.front();
    const std::size_t n = dim(), width = maps.with_hessian().width();
    if (xb_.size() < n * m) xb_.resize(n * m);
    if (gh_.size() < width * m) gh_.resize(width * m);
    maps.predictor().eval_batch(X, dt, xb_.data(), m, scratch_);
    maps.with_hessian().eval_batch(xb_.data(), dt, gh_.data(), m, scratch_);
    for (std::size_t j = 0; j < m; ++j) {
        for (std::size_t v = 0; v < n; ++v) x_[Eigen::Index(v)] = X[v * m + j];
        status[j] = stepper_[j].step_predicted(x_, dt, xb_.data() + j, gh_.data() + j, m, increment_);
        iterations_[j] = stepper_[j].last_iterations();
        residuals_[j] = stepper_[j].last_residual();
        for (std::size_t v = 0; v < n; ++v) increments[v * m + j] = increment_[Eigen::Index(v)];
    }
}

}  // namespace pgi
