#pragma once
// NewtonMatrix: J = alpha_x + alpha_p Hess S_dt, the Jacobian of the step's equation alpha(xb, grad S_dt(xb)) = x
// (docs/math.md 6), on its pattern fixed at build time, and its solve: partial-pivoting dense LU, or Eigen's
// SparseLU (COLAMD ordering; the symbolic analysis once, at build, a numeric factorisation per matrix).
#include "poisson/sparse_pattern.hpp"
#include "poisson/step_options.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>

#include <memory>

namespace pgi {

class NewtonMatrix {
public:
    /// Dense below this dimension: measured on the periodic Volterra lattice (k = 4, dt = 1/20, predictor order 2,
    /// J 9 entries a column), where the sparse step overtakes the dense one between n = 32 (dense 3.0, sparse
    /// 3.2 us per step and site) and 48 (5.9 against 3.4); SparseLU's bookkeeping costs more than a small dense LU.
    static constexpr std::size_t sparse_from_dimension = 40;
    /// The sparse solver for n >= sparse_from_dimension when J's pattern fills at most this fraction of n^2
    /// (the lattice at n = 40: 0.225).
    static constexpr double sparse_max_fill = 0.25;
    static NewtonSolver choose(NewtonSolverChoice choice, std::size_t n, std::size_t nonzeros);

    NewtonMatrix() = default;
    /// The patterns of alpha_x, alpha_p and Hess S_dt (n x n each); J's pattern is their sum and product's.
    NewtonMatrix(const SparsePattern& alpha_x, const SparsePattern& alpha_p, const SparsePattern& hessian,
                 NewtonSolverChoice choice);
    NewtonMatrix(const NewtonMatrix& other);
    NewtonMatrix& operator=(const NewtonMatrix& other);
    NewtonMatrix(NewtonMatrix&&) noexcept = default;
    NewtonMatrix& operator=(NewtonMatrix&&) noexcept = default;
    ~NewtonMatrix() = default;

    NewtonSolver solver() const { return solver_; }
    const SparsePattern& pattern() const { return pattern_; }
    /// J's values from the blocks' values, each in its pattern's order.
    void assemble(const double* alpha_x, const double* alpha_p, const double* hessian);
    /// dx = J^{-1} r with the last assembled J, factored and kept; false when the factorisation fails (J singular).
    bool solve(const Eigen::VectorXd& r, Eigen::VectorXd& dx);
    /// dx = J^{-1} r with the factors of the last solve (simplified Newton).
    bool solve_again(const Eigen::VectorXd& r, Eigen::VectorXd& dx);
    /// The last assembled J, dense.
    Eigen::MatrixXd dense() const;
    /// Multiply-adds of one assembly and factorisation, and of one solve with the factors, roughly (the
    /// predictor's cost model).
    double factor_cost() const;
    double solve_cost() const;

private:
    struct Product {
        int alpha_p, hessian, target;  // J[target] += alpha_p[alpha_p] * hessian[hessian]
    };
    using SparseLU = Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>>;
    void prepare_solver();

    NewtonSolver solver_ = NewtonSolver::dense;
    SparsePattern pattern_;
    std::vector<int> from_alpha_x_;  // entry k of alpha_x goes to J's entry from_alpha_x_[k]
    std::vector<Product> products_;
    std::vector<double> values_;
    Eigen::MatrixXd dense_;
    Eigen::PartialPivLU<Eigen::MatrixXd> dense_lu_;
    Eigen::SparseMatrix<double> sparse_;
    std::unique_ptr<SparseLU> sparse_lu_;  // SparseLU cannot be copied: a copy analyses the pattern anew
};

}  // namespace pgi
