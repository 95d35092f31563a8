#pragma once
// The Newton step's linear algebra, dense (docs/math.md 6): the Jacobian J = alpha_x + alpha_p Hess S_dt, the
// correction dx = J^{-1} r by partial-pivoting LU, and products Hess S_dt v. At the common small dimensions
// (n = 2, 3, 4, 6) on Eigen's fixed-size types, which live on the stack and unroll; dynamic beyond, with a
// preallocated LU. Allocates nothing after construction. (A sparse path would sit beside this one.)
#include <Eigen/Dense>

#include <variant>

namespace pgi {

class DenseAlgebra {
public:
    explicit DenseAlgebra(std::size_t n = 0);
    /// J = ax + ap H.
    void jacobian(const Eigen::MatrixXd& ax, const Eigen::MatrixXd& ap, const Eigen::MatrixXd& H,
                  Eigen::MatrixXd& J) const;
    /// dx = J^{-1} r, J factored and kept.
    void solve(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, Eigen::VectorXd& dx);
    /// dx = J^{-1} r with the J of the last solve(J, r, dx) (simplified Newton: the factors reused).
    void solve_again(const Eigen::VectorXd& r, Eigen::VectorXd& dx) const;
    /// out = H v.
    void product(const Eigen::MatrixXd& H, const Eigen::VectorXd& v, Eigen::VectorXd& out) const;

private:
    Eigen::Index n_ = 0;
    template <int N>
    using LU = Eigen::PartialPivLU<Eigen::Matrix<double, N, N>>;
    std::variant<Eigen::PartialPivLU<Eigen::MatrixXd>, LU<2>, LU<3>, LU<4>, LU<6>> lu_;
};

}  // namespace pgi
