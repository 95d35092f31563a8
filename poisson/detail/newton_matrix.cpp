#include "poisson/detail/newton_matrix.hpp"

#include <algorithm>

namespace pgi {

NewtonSolver NewtonMatrix::choose(NewtonSolverChoice choice, std::size_t n, std::size_t nonzeros) {
    switch (choice) {
        case NewtonSolverChoice::dense:
            return NewtonSolver::dense;
        case NewtonSolverChoice::sparse:
            return NewtonSolver::sparse;
        case NewtonSolverChoice::automatic:
            break;
    }
    const double fill = n ? double(nonzeros) / (double(n) * double(n)) : 1.0;
    return n >= sparse_from_dimension && fill <= sparse_max_fill ? NewtonSolver::sparse : NewtonSolver::dense;
}

NewtonMatrix::NewtonMatrix(const SparsePattern& ax, const SparsePattern& ap, const SparsePattern& h,
                           NewtonSolverChoice choice) {
    const std::size_t n = ax.rows;
    // J's pattern: alpha_x's entries, and (i, c) for every alpha_p(i, l) Hess(l, c)
    std::vector<std::vector<int>> columns(n);
    for (std::size_t c = 0; c < n; ++c) {
        columns[c].assign(ax.inner.begin() + ax.outer[c], ax.inner.begin() + ax.outer[c + 1]);
        for (int kh = h.outer[c]; kh < h.outer[c + 1]; ++kh) {
            const auto l = static_cast<std::size_t>(h.inner[std::size_t(kh)]);
            columns[c].insert(columns[c].end(), ap.inner.begin() + ap.outer[l], ap.inner.begin() + ap.outer[l + 1]);
        }
    }
    pattern_ = SparsePattern::from_columns(n, std::move(columns));
    for (std::size_t c = 0; c < n; ++c) {
        for (int k = ax.outer[c]; k < ax.outer[c + 1]; ++k)
            from_alpha_x_.push_back(int(pattern_.find(ax.inner[std::size_t(k)], int(c))));
        for (int kh = h.outer[c]; kh < h.outer[c + 1]; ++kh) {
            const auto l = static_cast<std::size_t>(h.inner[std::size_t(kh)]);
            for (int ka = ap.outer[l]; ka < ap.outer[l + 1]; ++ka)
                products_.push_back({ka, kh, int(pattern_.find(ap.inner[std::size_t(ka)], int(c)))});
        }
    }
    values_.assign(pattern_.nonzeros(), 0.0);
    solver_ = choose(choice, n, pattern_.nonzeros());
    prepare_solver();
}

void NewtonMatrix::prepare_solver() {
    const auto n = static_cast<Eigen::Index>(pattern_.rows);
    if (solver_ == NewtonSolver::dense) {
        dense_.setZero(n, n);
        dense_lu_ = Eigen::PartialPivLU<Eigen::MatrixXd>(n);
        return;
    }
    // the pattern with unit values (a generic matrix for the symbolic analysis); the order of Eigen's entries
    // is the pattern's (both sorted by row within each column), so values_ maps onto valuePtr() one to one
    std::vector<Eigen::Triplet<double>> entries;
    for (std::size_t c = 0; c < pattern_.cols; ++c)
        for (int k = pattern_.outer[c]; k < pattern_.outer[c + 1]; ++k)
            entries.emplace_back(pattern_.inner[std::size_t(k)], int(c), 1.0);
    sparse_.resize(n, n);
    sparse_.setFromTriplets(entries.begin(), entries.end());
    sparse_.makeCompressed();
    sparse_lu_ = std::make_unique<SparseLU>();
    sparse_lu_->analyzePattern(sparse_);
}

NewtonMatrix::NewtonMatrix(const NewtonMatrix& o)
    : solver_(o.solver_), pattern_(o.pattern_), from_alpha_x_(o.from_alpha_x_), products_(o.products_),
      values_(o.values_) {
    if (!pattern_.outer.empty()) prepare_solver();
}

NewtonMatrix& NewtonMatrix::operator=(const NewtonMatrix& o) {
    if (this != &o) *this = NewtonMatrix(o);
    return *this;
}

void NewtonMatrix::assemble(const double* ax, const double* ap, const double* h) {
    std::fill(values_.begin(), values_.end(), 0.0);
    for (std::size_t k = 0; k < from_alpha_x_.size(); ++k) values_[std::size_t(from_alpha_x_[k])] += ax[k];
    for (const Product& t : products_) values_[std::size_t(t.target)] += ap[t.alpha_p] * h[t.hessian];
}

bool NewtonMatrix::solve(const Eigen::VectorXd& r, Eigen::VectorXd& dx) {
    if (solver_ == NewtonSolver::dense) {
        pattern_.scatter(values_.data(), dense_);
        dense_lu_.compute(dense_);
        dx.noalias() = dense_lu_.solve(r);
        return true;  // a singular J shows as a non-finite dx, which the step reports
    }
    std::copy(values_.begin(), values_.end(), sparse_.valuePtr());
    sparse_lu_->factorize(sparse_);
    if (sparse_lu_->info() != Eigen::Success) return false;
    dx = sparse_lu_->solve(r);
    return true;
}

bool NewtonMatrix::solve_again(const Eigen::VectorXd& r, Eigen::VectorXd& dx) {
    if (solver_ == NewtonSolver::dense) {
        dx.noalias() = dense_lu_.solve(r);
        return true;
    }
    dx = sparse_lu_->solve(r);
    return true;
}

Eigen::MatrixXd NewtonMatrix::dense() const {
    Eigen::MatrixXd J;
    pattern_.scatter(values_.data(), J);
    return J;
}

double NewtonMatrix::solve_cost() const {
    const double n = double(pattern_.rows);
    return solver_ == NewtonSolver::dense ? 2 * n * n
                                          : 4 * double(pattern_.nonzeros());  // triangular solves on the factors' fill
}

double NewtonMatrix::factor_cost() const {
    const double n = double(pattern_.rows), nnz = double(pattern_.nonzeros());
    const double assembly = double(from_alpha_x_.size() + products_.size());
    if (solver_ == NewtonSolver::dense) return n * n * n / 3;  // the product alpha_p Hess is not counted (small n)
    // a factorisation of a pattern of bandwidth ~nnz/n costs ~n (nnz/n)^2, and SparseLU's supernodal
    // bookkeeping (depth-first searches, panels) ~400 multiply-adds' time per column (measured on the
    // lattice, n = 200..1000: one Newton iteration ~650 ns per site)
    return assembly + nnz * nnz / std::max(n, 1.0) + 400 * n;
}

}  // namespace pgi
