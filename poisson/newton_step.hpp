#pragma once
// NewtonStepper: the paper's Poisson integrator of order k (docs/math.md 6): solve alpha(xb, grad S_dt(xb)) = x
// for xb, then x_new = beta(xb, grad S_dt(xb)), written as x_new = x + (beta - alpha)(xb, grad S_dt(xb)).
// Its build has three named pieces: the realisation's truncation degree (poisson/detail/truncation_degree), the
// predictor (poisson/predictor), and here Newton with the acceptance test. dt is a run-time argument.
#include "poisson/dt_series.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/predictor.hpp"
#include "poisson/realisation.hpp"
#include "poisson/step_options.hpp"
#include "series/native.hpp"
#include "series/native_tier.hpp"
#include "series/value_ptr.hpp"

#include <Eigen/Dense>

#include <cstdint>
#include <memory>
#include <string>
#include <variant>

namespace pgi {

/// ok: alpha(xb, grad S_dt(xb)) = x holds at the accepted base point to its round-off tolerance and the
/// realisation's neglected terms there are below their bound. newton_not_converged: no iterate met the
/// tolerance (last_residual() and last_tolerance() say by how much). truncation_above_bound: solved, but
/// the truncated realisation's first neglected terms exceed StepOptions::truncation_bound (a smaller dt
/// or a closed form helps). ill_conditioned: the tolerance itself exceeds sqrt(u) max(|x|, |xb|), i.e. the
/// terms summed into alpha are ~1e6 times the state or more (or not finite): the equation no longer fixes
/// the state (a smaller dt helps). non_finite: a non-finite state or residual.
enum class StepStatus { ok, newton_not_converged, non_finite, truncation_above_bound, ill_conditioned };
std::string to_string(StepStatus s);

// The step over lanes (poisson/lane_step.hpp: GCC vector extensions), held by NewtonStepper where it exists and
// defined only where it runs, so this header and pgi.hpp do not pull the lane kernels in.
template <int N, class T>
class LaneStep;
struct LaneSteps;

class NewtonStepper {
public:
    NewtonStepper();
    NewtonStepper(const NewtonStepper&);
    NewtonStepper(NewtonStepper&&) noexcept;
    NewtonStepper& operator=(const NewtonStepper&);
    NewtonStepper& operator=(NewtonStepper&&) noexcept;
    ~NewtonStepper();

    /// Slow, exact: the realisation to the degree dt needs (chosen so the truncated terms are below
    /// round-off at x_typical), asked of realisation (which returns alpha and beta through a p-degree: the
    /// Scheme binds it to its own, built once), the series of the base point, grad S_j and Hess S_j and the
    /// predictor's u_m compiled to double, dt a run-time argument. S = S_1..S_k (opt.k of them). opt.dt is
    /// the largest dt the caller plans: the degree and the predictor's order are chosen for it (a larger dt
    /// at run time is guarded by the acceptance test). Requires pi to satisfy Jacobi. Throws
    /// std::invalid_argument on k < 1, S of another length, dt <= 0 or a bad x_typical. opt.native: always builds
    /// native code for the compiled maps now (series/native.hpp; info().native_maps says how many; NativeCodeError if
    /// it cannot be built); automatic attaches what the cache keeps and leaves the rest to a NativeTier shared with the
    /// copies of this stepper (native_maps() says how many maps run native code now).
    static NewtonStepper build(const PoissonStructure& pi, const std::vector<Poly>& S,
                               const RealisationSource& realisation, const StepOptions& opt,
                               const Eigen::VectorXd& x_typical);
    /// The same from H: the realisation and S_1..S_k computed here (poisson-level callers and tests).
    static NewtonStepper build(const PoissonStructure& pi, const Poly& H, const StepOptions& opt,
                               const Eigen::VectorXd& x_typical);

    /// Fast: increment = phi_dt(x) - x. Allocates nothing (on the dense path; SparseLU's factorisation allocates
    /// on the sparse one), throws nothing. dt is any positive step (a non-finite one returns non_finite); the
    /// realisation degree and predictor were chosen for built_dt(). Under NativePolicy::automatic one step in
    /// native_sample_period is timed for the NativeTier, which may then allocate once to start its build, and once
    /// more when this stepper switches to native code (adopt_native).
    [[nodiscard]] StepStatus step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment);
    /// The same at dt().
    [[nodiscard]] StepStatus step(const Eigen::VectorXd& x, Eigen::VectorXd& increment) {
        return step(x, dt_, increment);
    }
    /// step(x, dt, increment) with its first two evaluations given, as the batch step (poisson/batch_step) makes
    /// them for many states at once: xb[i stride] the predictor's xb at (x, dt), gh[i stride] with_hessian()'s
    /// output i at (xb, dt). The same status, increment and statistics as step(), bit for bit.
    [[nodiscard]] StepStatus step_predicted(const Eigen::VectorXd& x, double dt, const double* xb, const double* gh,
                                            std::size_t stride, Eigen::VectorXd& increment);
    /// What step_predicted is given: the predictor, and grad S_dt with Hess S_dt on its upper triangle (width()
    /// outputs; CompiledGradient).
    const Predictor& predictor() const;
    const DtSeriesMap& with_hessian() const;
    /// Dphi_dt(x) by implicit differentiation: I + (delta_x + delta_p Hess S) J^{-1} at the solution.
    Eigen::MatrixXd tangent_map(const Eigen::VectorXd& x);
    /// Sets jacobian (n x n) to the derivative of the last step's map at the state it stepped from, by the implicit
    /// function theorem at its accepted base point with the whole Hess S_dt (poisson/step_jacobian.cpp).
    /// Requires the last step to have returned ok. False when the Newton matrix there is singular (jacobian then not
    /// finite).
    bool last_step_jacobian(Eigen::MatrixXd& jacobian);

    /// One evaluation of the Newton system at xb, at dt(): F = alpha(xb, grad S_dt(xb)) and its Jacobian J.
    /// What one Newton iteration costs before the LU solve (the benchmarks' unit of work).
    const Eigen::MatrixXd& newton_system(const Eigen::VectorXd& xb);

    /// One step in this many is timed for the NativeTier (NativePolicy::automatic).
    static constexpr std::uint32_t native_sample_period = 256;
    /// The compiled maps that run native code now.
    std::size_t native_maps() const { return native_maps_; }
    /// The tier shared with this stepper's copies while native code may still come (NativePolicy::automatic, no kept
    /// library), else null.
    const NativeTier* native_tier() const { return native_tier_.get(); }
    /// Switches to native code if the tier's build is done (what the steps do every native_sample_period steps):
    /// attaches it, or keeps its failure (native_failure()), and lets the tier go.
    void adopt_native();
    /// The caller will take about `steps` more steps (integrate_steps says so, and 0 when its run ends): under
    /// NativePolicy::automatic, the first timed step starts native code's build at once where that many repay it
    /// (NativeTier::repays), rather than once the steps' time reaches the tier's share.
    void expect_steps(std::uint64_t steps) { expected_steps_ = steps; }
    /// Why native code could not be built under NativePolicy::automatic ("" if it was, or was not tried).
    const std::string& native_failure() const { return native_failure_; }

    int last_iterations() const { return iterations_; }
    /// |alpha(xb, p) - x|_inf at the last base point tested (the accepted one after an ok step).
    double last_residual() const { return residual_; }
    /// The residual's tolerance there: kappa u (|x| + sizes of the terms summed into alpha, and of those
    /// of grad S_dt through alpha_p), componentwise, kappa = 64; last_residual_ratio() = max_i |r_i| / tol_i.
    double last_tolerance() const { return tolerance_; }
    double last_residual_ratio() const { return ratio_; }
    /// The realisation's neglected terms at the last base point tested, relative to |x| (0 if exact).
    double last_truncation() const { return truncation_; }
    /// |alpha(xb, grad S_dt(xb)) - x|_inf at the base point the last step ended with (one more evaluation).
    double residual_at_solution(const Eigen::VectorXd& x);
    /// |alpha(xb, grad S_dt(xb)) - x|_inf at any xb, at dt(), evaluated as a simplified Newton iteration and the
    /// acceptance test evaluate it: grad S_dt and the realisation's values, no Hessian, no derivatives (what such an
    /// iteration costs beyond its solve; tools/bench/bench_step.cpp times it).
    double residual_at(const Eigen::VectorXd& x, const Eigen::VectorXd& xb);
    double last_correction() const { return correction_; }  // |dx|_inf of the last Newton update
    /// The base point xb the last step ended with (solving alpha(xb, grad S_dt(xb)) = x after an ok step).
    const Eigen::VectorXd& base_point() const { return xb_; }
    std::size_t order() const { return 2 * ((k_ + 1) / 2); }  // odeint's Stepper::order()
    /// The step of step(x, increment) and tangent_map: built_dt() unless set_dt changed it.
    double dt() const { return dt_; }
    /// Throws std::invalid_argument unless dt is positive and finite.
    void set_dt(double dt);
    /// The dt the build chose the realisation degree and the predictor for (StepOptions::dt).
    double built_dt() const { return opt_.dt; }
    std::size_t dim() const { return static_cast<std::size_t>(xb_.size()); }
    const StepInfo& info() const { return info_; }
    /// N when the step is LaneStep<N, double> (the dense step at N = 2, 3, 4, 6 with the so(3), log-canonical or
    /// compiled polynomial realisation; N = 3 for the so(3) form on the first three coordinates whatever dim(), the
    /// others having zero rows), which BatchStepper runs on lanes::width states at once; 0 otherwise.
    std::size_t lane_dimension() const;
    /// Sizes scratch for the lane kernel (series/compile_lanes.ipp) of the planned maps LaneStep runs on packs: grad
    /// and Hess S_dt, grad S_dt and the predictor. Here, in the baseline library, because a std::vector's growth must
    /// not be compiled for AVX2 (tests/lane_isa.sh).
    void size_lane_maps(BatchScratch& scratch) const;

private:
    template <int, class>
    friend class LaneStep;
    StepStatus lane_step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment);
    bool begin_step(const Eigen::VectorXd& x, double dt);  // false when x or dt is not finite
    StepStatus step_now(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment);
    void attach_native(NativePolicy policy);
    StepStatus sampled_step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment);  // timed for the tier
    StepStatus solve_from_prediction(const Eigen::VectorXd& x, Eigen::VectorXd& increment, bool evaluated);
    StepStatus newton(const Eigen::VectorXd& x, Eigen::VectorXd& increment, bool evaluated);
    void take_gradient_at(const Eigen::VectorXd& xb);
    const Eigen::MatrixXd& jacobian_at(const Eigen::VectorXd& xb);  // at step_dt_
    void evaluate_at(const Eigen::VectorXd& xb);
    bool accept_check(const Eigen::VectorXd& x, bool small_correction);
    bool within_tolerance();
    void add_propagated_sizes();
    StepStatus finish(double x_norm, Eigen::VectorXd& increment);
    void polish(Eigen::VectorXd& increment);
    bool solve(bool again);
    void size_scratch(std::size_t n);
    std::vector<CompiledMap*> compiled_maps();  // every map the step evaluates, for native code (StepOptions::native)
    void assemble();                            // J at the point evaluate_at saw
    const Eigen::VectorXd& evaluated_alpha() const;
    const Eigen::VectorXd& evaluated_delta() const;

    std::size_t k_ = 1;
    double dt_ = 0;       // the default step
    double step_dt_ = 0;  // the step being taken
    StepOptions opt_;
    StepInfo info_;
    // the realisation's evaluator, the maps, the predictor, the Newton matrix: poisson/detail/newton_internals.hpp
    struct Internals;
    ValuePtr<Internals> in_;
    bool sparse_ = false;
    // the coordinates sizes are measured over (PoissonStructure::moving_dimension: a scheme's parameters excluded)
    std::size_t moving_ = 0;
    double state_norm(const Eigen::VectorXd& v) const {
        return v.head(Eigen::Index(moving_)).lpNorm<Eigen::Infinity>();
    }
    Eigen::VectorXd gsize_, tol_, moved_;             // moved_: the polishing round's first-order change of delta
    Eigen::VectorXd xb_, xb_good_, p_, r_, dx_, gh_;  // gh_: with_hessian's outputs (the Hessian's upper triangle)
    Eigen::VectorXd hessian_;                         // Hess S_dt on its whole pattern (expand_hessian)
    Eigen::MatrixXd hess_, J_, D_;
    // the same step over lanes, where it exists (then step() is its one-lane instantiation); empty otherwise
    ValuePtr<LaneSteps> lane_;
    std::shared_ptr<NativeTier> native_tier_;  // shared with the copies; null once settled or not wanted
    std::uint32_t native_countdown_ = 0;  // steps to the next timed one (wraps: never, in practice, without a tier)
    std::uint64_t expected_steps_ = 0;    // expect_steps, less native_sample_period at each timed step
    std::size_t native_maps_ = 0;
    std::string native_failure_;
    int iterations_ = 0;
    double residual_ = 0, correction_ = 0, tolerance_ = 0, ratio_ = 0, truncation_ = 0;
};

}  // namespace pgi
