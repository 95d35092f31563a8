#include "poisson/sparse_pattern.hpp"

#include <algorithm>

namespace pgi {

SparsePattern SparsePattern::from_columns(std::size_t rows, std::vector<std::vector<int>> columns) {
    SparsePattern p;
    p.rows = rows;
    p.cols = columns.size();
    p.outer.push_back(0);
    for (auto& c : columns) {
        std::sort(c.begin(), c.end());
        c.erase(std::unique(c.begin(), c.end()), c.end());
        p.inner.insert(p.inner.end(), c.begin(), c.end());
        p.outer.push_back(static_cast<int>(p.inner.size()));
    }
    return p;
}

SparsePattern SparsePattern::dense(std::size_t rows, std::size_t cols) {
    std::vector<int> all(rows);
    for (std::size_t r = 0; r < rows; ++r) all[r] = static_cast<int>(r);
    return from_columns(rows, std::vector<std::vector<int>>(cols, all));
}

std::ptrdiff_t SparsePattern::find(int r, int c) const {
    const auto first = inner.begin() + outer[std::size_t(c)], last = inner.begin() + outer[std::size_t(c) + 1];
    const auto it = std::lower_bound(first, last, r);
    return it != last && *it == r ? it - inner.begin() : -1;
}

void SparsePattern::multiply(const double* values, const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    y.setZero();
    for (std::size_t c = 0; c < cols; ++c) {
        const double xc = x[Eigen::Index(c)];
        for (int k = outer[c]; k < outer[c + 1]; ++k) y[inner[std::size_t(k)]] += values[k] * xc;
    }
}

void SparsePattern::scatter(const double* values, Eigen::MatrixXd& dense) const {
    dense.setZero(Eigen::Index(rows), Eigen::Index(cols));
    for (std::size_t c = 0; c < cols; ++c)
        for (int k = outer[c]; k < outer[c + 1]; ++k) dense(inner[std::size_t(k)], Eigen::Index(c)) = values[k];
}

}  // namespace pgi
