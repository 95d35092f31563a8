#pragma once
// SparsePattern: where a matrix of the step (a derivative block of the realisation, the Hessian of S_dt, the
// Newton matrix) can be non-zero, fixed once at build time, in compressed-column form (Eigen's and
// SparseLU's layout): values are stored in pattern order, entry k at (inner[k], its column).
#include "series/poly.hpp"

#include <Eigen/Dense>

#include <cstddef>
#include <vector>

namespace pgi {

struct SparsePattern {
    std::size_t rows = 0, cols = 0;
    std::vector<int> outer;  // column c holds the entries outer[c] .. outer[c + 1] - 1
    std::vector<int> inner;  // their rows, increasing within each column

    /// From the rows of each column (any order, repeats allowed).
    static SparsePattern from_columns(std::size_t rows, std::vector<std::vector<int>> columns);
    /// Every entry of a rows x cols matrix.
    static SparsePattern dense(std::size_t rows, std::size_t cols);
    std::size_t nonzeros() const { return inner.size(); }
    /// The index of entry (r, c) in pattern order, or -1 if the pattern does not hold it.
    std::ptrdiff_t find(int r, int c) const;
    /// y = A x for the matrix with these values.
    void multiply(const double* values, const Eigen::VectorXd& x, Eigen::VectorXd& y) const;
    /// The dense matrix with these values (zero off the pattern).
    void scatter(const double* values, Eigen::MatrixXd& dense) const;
};

}  // namespace pgi
