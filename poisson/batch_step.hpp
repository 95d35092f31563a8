#pragma once
// BatchStepper: one compiled step advancing m states together (heyoka's batch mode). Where the step has a lane
// form (NewtonStepper::lane_dimension(): the dense step at N = 2, 3, 4, 6 with the so(3) or the compiled
// polynomial realisation) the states go lanes::width at a time through LaneStep<N, Pack> (Pack4 on AVX2): the
// predictor, the evaluations, the Jacobian and its LU, the acceptance test all act on the lanes together (SIMD), each
// lane with its own Newton control as masks. Otherwise the predictor and the first grad and Hess S_dt are evaluated for
// all states at once (CompiledMap::eval_batch) and Newton goes on state by state (step_predicted). Either way each
// state's result is its single step's bit for bit.
#include "poisson/lane_step.hpp"
#include "poisson/newton_step.hpp"

#include <variant>
#include <vector>

namespace pgi {

/// Which instructions the lane form runs on: AVX2 where the processor has it (automatic), or as asked (the tests
/// run both; asking for AVX2 on a processor without it throws std::invalid_argument).
enum class LaneInstructions { automatic, sse2, avx2 };

class BatchStepper {
public:
    /// Up to lanes states per step, stepped as prototype steps one.
    BatchStepper(const NewtonStepper& prototype, std::size_t lanes,
                 LaneInstructions instructions = LaneInstructions::automatic);
    /// What the lane form runs on (sse2 or avx2), or automatic when the step has no lane form.
    LaneInstructions instructions() const { return instructions_; }

    std::size_t lanes() const { return capacity_; }
    std::size_t dim() const { return stepper_.front().dim(); }
    /// The states X[v m + j] (coordinate v of state j, m <= lanes()) one step of dt further:
    /// increments[v m + j] = phi_dt(x_j) - x_j and status[j], each NewtonStepper::step(x_j, dt)'s bit for bit.
    /// Allocates nothing once it has stepped m states (on the dense path).
    void step(const double* X, std::size_t m, double dt, double* increments, StepStatus* status);
    /// State j's Newton statistics after the last step, as NewtonStepper's.
    int last_iterations(std::size_t j) const { return iterations_[j]; }
    double last_residual(std::size_t j) const { return residuals_[j]; }

private:
    template <int N, class Pack>
    void step_lanes(LaneStep<N, Pack>& lane, const double* X, std::size_t m, double dt, double* increments,
                    StepStatus* status);
    void step_predicted(const double* X, std::size_t m, double dt, double* increments, StepStatus* status);

    std::size_t capacity_ = 0;
    std::vector<NewtonStepper>
        stepper_;  // the lane form: one (its maps); otherwise one per state, the first's maps serving all
    LaneInstructions instructions_ = LaneInstructions::automatic;
    std::variant<std::monostate, LaneStep<2, lanes::Pack>, LaneStep<3, lanes::Pack>, LaneStep<4, lanes::Pack>,
                 LaneStep<6, lanes::Pack>, LaneStep<2, lanes::Pack4>, LaneStep<3, lanes::Pack4>,
                 LaneStep<4, lanes::Pack4>, LaneStep<6, lanes::Pack4>>
        lane_;
    std::vector<int> iterations_;
    std::vector<double> residuals_;
    std::vector<double> xb_, gh_;  // state by state: the predicted base points, grad and Hess S_dt there
    BatchScratch scratch_;
    Eigen::VectorXd x_, increment_;
};

}  // namespace pgi
