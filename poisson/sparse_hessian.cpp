#include "poisson/sparse_hessian.hpp"

#include "poisson/realisation_eval.hpp"

#include <stdexcept>

namespace pgi {

CompiledGradient compile_gradient(const PhaseSpace& M, const std::vector<Poly>& S, double planned_dt) {
    const std::size_t n = M.dim();
    std::vector<std::vector<Poly>> grad(S.size()), sizes(S.size()), with_hessian(S.size());
    std::vector<std::vector<int>> columns(n);
    for (std::size_t j = 0; j < S.size(); ++j) {
        for (std::size_t l = 0; l < n; ++l) grad[j].push_back(derivative(S[j], M.x(l)));
        for (const auto& g : grad[j]) sizes[j].push_back(absolute_coefficients(g));
        for (std::size_t c = 0; c < n; ++c)
            for (std::size_t v : used_variables(grad[j][c]))
                if (v < n) columns[c].push_back(static_cast<int>(v));  // the coordinates are ring variables 0..n-1
    }
    CompiledGradient g;
    g.hessian = SparsePattern::from_columns(n, std::move(columns));
    // the entries r <= c numbered in pattern order; (c, r) with r < c (in an earlier column) takes (r, c)'s number
    const SparsePattern& P = g.hessian;
    g.hessian_value.assign(P.nonzeros(), 0);
    std::uint32_t upper = 0;
    for (std::size_t c = 0; c < n; ++c)
        for (int k = P.outer[c]; k < P.outer[c + 1]; ++k)
            if (std::size_t(P.inner[std::size_t(k)]) <= c) g.hessian_value[std::size_t(k)] = upper++;
    for (std::size_t c = 0; c < n; ++c)
        for (int k = P.outer[c]; k < P.outer[c + 1]; ++k) {
            const int r = P.inner[std::size_t(k)];
            if (std::size_t(r) <= c) continue;
            const std::ptrdiff_t mirror = P.find(static_cast<int>(c), r);
            if (mirror < 0) throw std::logic_error("compile_gradient: the Hessian's pattern is not symmetric");
            g.hessian_value[std::size_t(k)] = g.hessian_value[std::size_t(mirror)];
        }
    for (std::size_t j = 0; j < S.size(); ++j) {
        with_hessian[j] = grad[j];
        for (std::size_t c = 0; c < n; ++c)
            for (int k = P.outer[c]; k < P.outer[c + 1]; ++k)
                if (const auto r = std::size_t(P.inner[std::size_t(k)]); r <= c) with_hessian[j].push_back(derivative(grad[j][c], M.x(r)));
    }
    const auto inputs = M.coordinate_vars();
    g.with_hessian = DtSeriesMap::build(with_hessian, inputs, planned_dt);
    g.gradient = DtSeriesMap::build(grad, inputs, planned_dt);
    g.gradient_size = DtSeriesMap::build(sizes, inputs);  // read at |x| and |dt|: no planned sum
    return g;
}

void expand_hessian(const CompiledGradient& g, const double* upper, double* values) {
    for (std::size_t k = 0; k < g.hessian_value.size(); ++k) values[k] = upper[g.hessian_value[k]];
}

}  // namespace pgi
