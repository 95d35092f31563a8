#pragma once
// The Newton step's linear algebra, dense (docs/math.md 6): the Jacobian J = alpha_x + alpha_p Hess S_dt, the
// correction dx = J^{-1} r by partial-pivoting LU, and products Hess S_dt v. At the common small dimensions
// (n = 2, 3, 4, 6) on Eigen's fixed-size types, which live on the stack and unroll; dynamic beyond, with a
// preallocated LU. Allocates nothing after construction. (A sparse path would sit beside this one.)
#include <Eigen/Dense>

namespace pgi {

class DenseAlgebra {
public:
    explicit DenseAlgebra(std::size_t n = 0);
    /// J = ax + ap H.
    void jacobian(const Eigen::MatrixXd& ax, const Eigen::MatrixXd& ap, const Eigen::MatrixXd& H, Eigen::MatrixXd& J) const;
    /// dx = J^{-1} r.
    void solve(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, Eigen::VectorXd& dx);
    /// out = H v.
    void product(const Eigen::MatrixXd& H, const Eigen::VectorXd& v, Eigen::VectorXd& out) const;

private:
    Eigen::Index n_ = 0;
    Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace pgi
