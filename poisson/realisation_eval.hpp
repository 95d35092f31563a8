#pragma once
// RealisationEvaluator: alpha, beta - alpha and their first derivatives at a point (x, p), in double.
#include "poisson/realisation.hpp"
#include "series/compile.hpp"

#include <Eigen/Dense>

namespace pgi {

/// What one evaluation produces; every block is sized once by the evaluator and reused.
struct RealisationValues {
    Eigen::VectorXd alpha, delta;                        // alpha(x, p) and delta = beta - alpha
    Eigen::MatrixXd alpha_x, alpha_p, delta_x, delta_p;  // d/dx and d/dp of each (row i: component i)
    explicit RealisationValues(std::size_t n = 0);
};

/// One of: a compiled polynomial realisation (any class, truncated at p-degree D); the log-canonical
/// closed form alpha_j = x_j exp(u_j), u_j = (1/2) sum_i a_ij x_i p_i, exact in floating point; or the
/// Lie-Poisson form alpha = sum_{m<=D} B_m/m! L(p)^m x evaluated by matrix-vector products (docs/math.md 3).
/// delta = beta - alpha is computed as its own expression (-2 x_j sinh u_j; L(p) x, since the odd
/// Bernoulli numbers past B_1 vanish; or the odd part of the series), so small steps do not cancel.
class RealisationEvaluator {
public:
    RealisationEvaluator() = default;
    static RealisationEvaluator polynomial(const PoissonStructure& pi, const Realisation& r);
    static RealisationEvaluator log_canonical(const PoissonStructure& pi);
    static RealisationEvaluator lie_poisson(const PoissonStructure& pi, std::size_t D);
    /// so(3)*-type structures (n = 3, linear, every C_j skew, so L(p) is skew and L^3 = -s L): the
    /// series summed in closed form, alpha = x - L x / 2 + h(s) L^2 x, exact in floating point.
    static bool has_rotation_form(const PoissonStructure& pi);
    static RealisationEvaluator rotation(const PoissonStructure& pi);

    /// One evaluation's cost in multiply-adds, roughly (transcendentals counted as 20): for cost models.
    std::size_t cost() const;

    /// Writes every block of v. Allocates nothing.
    void eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;

private:
    enum class Form { polynomial, log_canonical, lie_poisson, rotation };
    void eval_log_canonical(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    void eval_lie_poisson(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    void eval_rotation(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;

    std::size_t n_ = 0;
    Form form_ = Form::polynomial;
    Eigen::MatrixXd a_;                 // log-canonical: a_ij
    std::vector<Eigen::MatrixXd> C_;    // Lie-Poisson: C_[j](i, k) = c_ij^k = dL(p)/dp_j
    std::vector<double> b_;             // Lie-Poisson: B_m / m!, m = 0..D; rotation: B_2j / (2j)!, j = 1..20
    CompiledMap map_;                   // polynomial: alpha, delta, alpha_x, alpha_p, delta_x, delta_p
    mutable Eigen::VectorXd in_, out_, u_, v_prev_, v_next_;
    mutable Eigen::MatrixXd L_, W_prev_, W_next_, power_, tmp_;
};

}  // namespace pgi
