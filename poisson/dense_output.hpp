#pragma once
// DenseOutput: a continuous extension of one step x0 -> x1 of size dt, of the method's order: the
// two-point Hermite polynomial in theta = (t - t0)/dt matching, at both ends, the state and the
// derivatives d^j x/dt^j = L_f^j x (j = 1..m) of the flow of f = pi grad H through it.
// The Lie derivatives L_f^j x are exact polynomials (FLINT), compiled once.
//
// Order: the interpolant has degree 2m + 1, so it differs from a smooth curve matching those data by
// O(dt^(2m+2)); the end point x1 is the step's, off the flow through x0 by the local error O(dt^(p+1))
// of a method of order p, and that error is carried into the interior. With m = p/2 the interpolation
// error O(dt^(p+2)) is below the step's own: the dense output's local error is O(dt^(p+1)), the step's.
#include "poisson/structure.hpp"
#include "series/compile.hpp"

#include <Eigen/Dense>

#include <vector>

namespace pgi {

/// L_f^j x for j = 1..m: out[j-1][i] = d^j x_i / dt^j along the flow of f, as polynomials in x.
/// Throws ResourceLimitError if a product outgrows the ring's term limit.
std::vector<std::vector<Poly>> lie_derivatives(const PoissonStructure& pi, const Poly& H, std::size_t m);

class DenseOutput {
public:
    DenseOutput() = default;
    /// Slow, exact: the Lie derivatives of x through order m = max(1, method_order / 2), compiled.
    static DenseOutput build(const PoissonStructure& pi, const Poly& H, std::size_t method_order);

    /// Fits the interpolant of the step x0 -> x1 of size dt. Reuses the derivatives at x0 when x0 is
    /// the previous fit's x1. Allocates nothing.
    void fit(const Eigen::VectorXd& x0, const Eigen::VectorXd& x1, double dt);
    /// The interpolant at theta in [0, 1] (t = t0 + theta dt): out has dim() entries.
    void eval(double theta, double* out) const;
    /// Its derivative with respect to theta (dt times the time derivative).
    void eval_derivative(double theta, double* out) const;

    std::size_t dim() const { return static_cast<std::size_t>(x0_.size()); }
    std::size_t derivatives() const { return m_; }     // m
    std::size_t degree() const { return 2 * m_ + 1; }  // of the interpolant in theta
    /// Its compiled map (the Lie derivatives), for code to be attached to.
    std::vector<CompiledMap*> compiled_maps() { return {&lie_}; }

private:
    void derivatives_at(const Eigen::VectorXd& x, Eigen::MatrixXd& d) const;

    std::size_t m_ = 0;
    CompiledMap lie_;          // x -> L_f^j x, j = 1..m (n m outputs, j-major)
    Eigen::MatrixXd high_;     // maps the end conditions to the coefficients of theta^(m+1..2m+1)
    Eigen::MatrixXd d0_, d1_;  // n x m: column j - 1 = d^j x/dt^j at x0, at x1
    Eigen::MatrixXd coeff_;    // n x (2m + 2): the interpolant's coefficients in theta, relative to x0
    Eigen::VectorXd x0_, cached_x1_, rhs_;
    bool cached_ = false;
};

}  // namespace pgi
