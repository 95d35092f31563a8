#include "poisson/sparse_hessian.hpp"

#include "poisson/realisation_eval.hpp"

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
    for (std::size_t j = 0; j < S.size(); ++j) {
        with_hessian[j] = grad[j];
        for (std::size_t c = 0; c < n; ++c)
            for (int k = g.hessian.outer[c]; k < g.hessian.outer[c + 1]; ++k)
                with_hessian[j].push_back(derivative(grad[j][c], M.x(std::size_t(g.hessian.inner[std::size_t(k)]))));
    }
    const auto inputs = M.coordinate_vars();
    g.with_hessian = DtSeriesMap::build(with_hessian, inputs, planned_dt);
    g.gradient = DtSeriesMap::build(grad, inputs, planned_dt);
    g.gradient_size = DtSeriesMap::build(sizes, inputs);  // read at |x| and |dt|: no planned sum
    return g;
}

}  // namespace pgi
