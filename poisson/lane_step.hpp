#pragma once
// LaneStep: NewtonStepper's dense step at a small fixed dimension N (2, 3, 4, 6), written once over lanes
// (poisson/lanes.hpp). N is the number of the stepper's leading coordinates Newton solves for
// (RealisationEvaluator::leading_dimension): the others, which its realisation leaves alone (a scheme's parameters),
// are inputs of its maps and step by exactly zero (their rows of the Newton matrix are e_w, and its columns for them
// multiply a zero correction). T = double steps one state: it is NewtonStepper::step there. T = lanes::Pack steps
// lanes::width states together (BatchStepper): every evaluation, the Jacobian, its LU (its inverse for N <= 4) and the
// acceptance test run on all lanes at once, and each lane keeps its own Newton control (its iteration, backtracking,
// simplified Newton, second attempt from xb = x) as masks. A lane's operations are the double instantiation's
// in the same order, so its increment, status and statistics are the single step's bit for bit.
// The algorithm is NewtonStepper::newton's (docs/math.md 6); the linear algebra is written out here
// (Eigen's fixed-size kernels differ between a 3 x 3 and 8 lanes of one).
#include "poisson/dt_series.hpp"
#include "poisson/lanes.hpp"
#include "poisson/realisation_eval.hpp"

#include <variant>
#include <vector>

namespace pgi {

class NewtonStepper;
enum class StepStatus;

/// sizeof and alignof of the types the lane kernels read, as the baseline files and as the AVX2 file (compiled
/// with other options, poisson/lane_step_avx2.cpp) see them: a test checks that they agree (one layout per type).
struct LaneLayout {
    std::size_t values[8];
    bool operator==(const LaneLayout&) const = default;
};
/// Data, not functions: the AVX2 file exports no code but its Pack4 kernels (tests/lane_isa.sh).
extern const LaneLayout baseline_lane_layout, avx2_lane_layout;

template <int N, class T>
class LaneStep {
public:
    static constexpr std::size_t lanes = lanes::lanes_of<T>;
    static constexpr int dimension = N;
    using Mask = lanes::mask_t<T>;

    /// Scratch sized for stepper's maps.
    explicit LaneStep(const NewtonStepper& stepper);
    /// x (N values over lanes) one step of dt further with stepper's maps and options: increment[i] (lane w)
    /// = phi_dt(x) - x and status[w], each as NewtonStepper::step's; a lane whose step fails keeps its increment.
    /// The coordinates past the first N take the values in passive() (their increment is zero).
    void step(const NewtonStepper& stepper, const T* x, double dt, T* increment, StepStatus* status);
    /// The values of the stepper's coordinates past the first N (dim - N of them), for the caller to set.
    T* passive() { return passive_.data(); }
    /// Which of the caller's blocks of lanes the steps that follow take (a caller stepping several in turn): each
    /// keeps its own coefficients of the maps read through the passive values (CompiledMap's slow inputs).
    void set_block(std::size_t b) { dt_maps_.coefficients.set_first_block(b); }

    /// Lane w's statistics after the last step (NewtonStepper's last_* accessors).
    int iterations(std::size_t w) const { return static_cast<int>(lanes::lane(iterations_, w)); }
    double residual(std::size_t w) const { return lanes::lane(residual_, w); }
    double tolerance(std::size_t w) const { return lanes::lane(tolerance_, w); }
    double ratio(std::size_t w) const { return lanes::lane(ratio_, w); }
    double truncation(std::size_t w) const { return lanes::lane(truncation_, w); }
    double correction(std::size_t w) const { return lanes::lane(correction_, w); }
    double base_point(std::size_t i, std::size_t w) const {
        return lanes::lane(i < std::size_t(N) ? xb_[i] : passive_[i - std::size_t(N)], w);
    }

private:
    void round(const NewtonStepper& s, T* increment);
    void evaluate(const NewtonStepper& s, Mask F, T* J);
    Mask accept_check(const NewtonStepper& s, Mask C, Mask small);
    void finish(const NewtonStepper& s, Mask E, T* increment);
    void polish(Mask E, T* delta) const;  // delta moved where the lanes of E polish
    void factor(Mask F, const T* J);
    const T* inputs(const T* point, bool magnitudes);
    void solve_kept(const T* b, T* d) const;
    void restart(Mask R);
    [[gnu::always_inline]] inline void end(Mask E, StepStatus st);
    void close_round(const NewtonStepper& s, StepStatus* status);

    double dt_ = 0;
    T x_[N], xb_[N], good_[N], p_[N], r_[N], dx_[N], H_[N * N], pivot_inverse_[N];
    T lu_[N * N];  // J's LU factors, or for N <= 4 J^{-1} (factor)
    int hessian_to_[N * N] = {}, hessian_from_[N * N] = {}, hessian_count_ = 0;  // H[to[k]] = gh_[from[k]], k < count
    Mask swaps_[N * (N - 1) / 2 + 1];  // the LU's row exchanges, as masks, in the order it made them
    LaneRealisation<N, T> values_;
    LaneCheck<N, T> check_;
    std::vector<T> gh_, scratch_;      // grad and Hess S_dt on its pattern; grad S_dt or its sizes (every coordinate's)
    std::vector<T> passive_, inputs_;  // the coordinates past N; the maps' inputs, when there are such coordinates
    LaneMapScratch<T> maps_;
    // the coordinates sizes are measured over, the first moving_ (NewtonStepper's: a scheme's parameters excluded)
    std::size_t moving_;
    T state_norm(const T* v) const;
    BatchScratch dt_maps_;
    // each lane's Newton: its statistics, its control (NewtonStepper::newton's locals) and whether it runs
    T iterations_{}, residual_{}, tolerance_{}, ratio_{}, truncation_{}, correction_{};
    T previous_{}, previous_residual_{}, good_residual_{}, lambda_{}, x_norm_{}, it_{}, spent_{};
    T ended_code_{};  // what newton returned in this round (a StepStatus as a number), for the lanes in ended_
    Mask running_{}, simplified_{}, second_{}, ended_{};
};

// Each instantiation is compiled in one file, for its instruction set: double and Pack in lane_step.cpp, Pack4 in
// lane_step_avx2.cpp (-mavx2). Declared here, so that no other file compiles a copy of its own: a unity build puts
// batch_step.cpp in the unit of lane_step.cpp, where the members' definitions are visible, and the baseline copy
// of the Pack4 kernels it made was the one the linker kept (ctest lane_isa checks the program).
extern template class LaneStep<2, double>;
extern template class LaneStep<3, double>;
extern template class LaneStep<4, double>;
extern template class LaneStep<6, double>;
extern template class LaneStep<2, lanes::Pack>;
extern template class LaneStep<3, lanes::Pack>;
extern template class LaneStep<4, lanes::Pack>;
extern template class LaneStep<6, lanes::Pack>;
extern template class LaneStep<2, lanes::Pack4>;
extern template class LaneStep<3, lanes::Pack4>;
extern template class LaneStep<4, lanes::Pack4>;
extern template class LaneStep<6, lanes::Pack4>;

/// The lane step a NewtonStepper holds (poisson/newton_step.hpp), one of its dimensions.
struct LaneSteps {
    template <class Lane>
    LaneSteps(std::in_place_type_t<Lane> lane, const NewtonStepper& stepper) : step(lane, stepper) {}
    std::variant<LaneStep<2, double>, LaneStep<3, double>, LaneStep<4, double>, LaneStep<6, double>> step;
};

}  // namespace pgi
