#pragma once
// NewtonStepper: the paper's Poisson integrator of order k (docs/math.md 6): solve alpha(xb, grad S_dt(xb)) = x
// for xb, then x_new = beta(xb, grad S_dt(xb)), written as x_new = x + (beta - alpha)(xb, grad S_dt(xb)).
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/newton_matrix.hpp"
#include "poisson/realisation_eval.hpp"
#include "poisson/sparse_hessian.hpp"

#include <Eigen/Dense>

#include <string>

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

struct StepOptions {
    std::size_t k = 2;                    // Hamilton-Jacobi order
    double dt = 0.1;
    RealisationChoice realisation = RealisationChoice::automatic;
    std::size_t max_degree = 24;          // cap on the p-degree D of a truncated realisation
    int newton_max_iter = 100;            // evaluations, backtracking included (large steps may need 30-70)
    double newton_tol = 1e-9;             // try the acceptance test once |dx| <= tol max(|x|, |xb|): the next correction is ~|dx|^2
    double truncation_bound = 1e-12;      // a truncated realisation's neglected terms at the solution, relative to |x|
    std::size_t predictor_order = 0;      // P of the base point's series; 0 chooses it by cost, up to max(k + 1, 6)
    NewtonSolverChoice solver = NewtonSolverChoice::automatic;  // the Newton matrix dense or sparse (NewtonMatrix::choose)
};

/// How the step was built: the realisation's method and degree, and the size of the neglected
/// terms at the typical state (zero for exact closed forms).
struct StepInfo {
    std::string method;
    std::size_t degree = 0;               // D (0 for the log-canonical closed form, which has no truncation)
    bool exact_realisation = false;
    double truncation_estimate = 0;       // max_{m > D} |A_m(x, grad S_dt(x))|_inf / |x|_inf at the typical state (probed degrees)
    std::size_t predictor_order = 0;      // the base point is predicted by its exact series in dt to this order
    NewtonSolver solver = NewtonSolver::dense;  // sparse: J, the Hessian and the realisation's derivatives on their patterns
};

class NewtonStepper {
public:
    /// Slow, exact: S_1..S_k, the realisation to the degree dt needs (chosen so the truncated terms
    /// are below round-off at x_typical), the series of the base point, all compiled to double.
    /// Requires pi to satisfy Jacobi. Throws std::invalid_argument on k < 1, dt <= 0 or a bad x_typical.
    static NewtonStepper build(const PoissonStructure& pi, const Poly& H, const StepOptions& opt,
                               const Eigen::VectorXd& x_typical);

    /// Fast: increment = phi_dt(x) - x. Allocates nothing, throws nothing.
    [[nodiscard]] StepStatus step(const Eigen::VectorXd& x, Eigen::VectorXd& increment);
    /// Dphi_dt(x) by implicit differentiation: I + (delta_x + delta_p Hess S) J^{-1} at the solution.
    Eigen::MatrixXd tangent_map(const Eigen::VectorXd& x);

    /// One evaluation of the Newton system at xb: F = alpha(xb, grad S_dt(xb)) and its Jacobian J.
    /// What one Newton iteration costs before the LU solve (the benchmarks' unit of work).
    const Eigen::MatrixXd& newton_system(const Eigen::VectorXd& xb);

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
    double last_correction() const { return correction_; }  // |dx|_inf of the last Newton update
    /// The base point xb the last step ended with (solving alpha(xb, grad S_dt(xb)) = x after an ok step).
    const Eigen::VectorXd& base_point() const { return xb_; }
    std::size_t order() const { return 2 * ((k_ + 1) / 2); }  // odeint's Stepper::order()
    double dt() const { return dt_; }
    std::size_t dim() const { return static_cast<std::size_t>(xb_.size()); }
    const StepInfo& info() const { return info_; }

private:
    StepStatus newton(const Eigen::VectorXd& x, Eigen::VectorXd& increment);
    void evaluate_at(const Eigen::VectorXd& xb);
    bool accept_check(const Eigen::VectorXd& x, bool small_correction);
    bool within_tolerance();
    void add_propagated_sizes();
    void size_scratch(std::size_t n);
    void assemble();
    const Eigen::VectorXd& evaluated_alpha() const { return sparse_ ? sparse_values_.alpha : v_.alpha; }
    const Eigen::VectorXd& evaluated_delta() const { return sparse_ ? sparse_values_.delta : v_.delta; }

    std::size_t k_ = 1;
    double dt_ = 0;
    StepOptions opt_;
    StepInfo info_;
    RealisationEvaluator realisation_;
    CompiledGradient gradient_;           // x -> grad S_dt (n), Hess S_dt on its pattern; grad S_dt alone; its terms' sizes
    CompiledMap predictor_;               // x -> xb, the base point's series in dt
    NewtonMatrix matrix_;                 // the sparse path's J (unused on the dense path)
    bool sparse_ = false;
    SparseRealisationValues sparse_values_;
    RealisationCheck check_;
    Eigen::VectorXd gsize_, tol_;
    RealisationValues v_;
    Eigen::VectorXd xb_, xb_good_, p_, r_, dx_, gh_;
    Eigen::MatrixXd hess_, J_, D_;
    Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
    int iterations_ = 0;
    double residual_ = 0, correction_ = 0, tolerance_ = 0, ratio_ = 0, truncation_ = 0;
};

}  // namespace pgi
