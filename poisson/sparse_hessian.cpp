#include "poisson/sparse_hessian.hpp"

#include "poisson/realisation_eval.hpp"

namespace pgi {

CompiledGradient compile_gradient(const PhaseSpace& M, const Poly& S) {
    const std::size_t n = M.dim();
    std::vector<Poly> grad, sizes;
    for (std::size_t l = 0; l < n; ++l) grad.push_back(derivative(S, M.x(l)));
    for (const auto& g : grad) sizes.push_back(absolute_coefficients(g));
    std::vector<std::vector<int>> columns(n);
    std::vector<Poly> outputs = grad;
    for (std::size_t c = 0; c < n; ++c) {
        for (std::size_t v : used_variables(grad[c]))
            if (v < n) columns[c].push_back(static_cast<int>(v));  // the coordinates are ring variables 0..n-1
    }
    CompiledGradient g;
    g.hessian = SparsePattern::from_columns(n, std::move(columns));
    for (std::size_t c = 0; c < n; ++c)
        for (int k = g.hessian.outer[c]; k < g.hessian.outer[c + 1]; ++k)
            outputs.push_back(derivative(grad[c], M.x(std::size_t(g.hessian.inner[std::size_t(k)]))));
    const auto inputs = M.coordinate_vars();
    g.with_hessian = CompiledMap::build(outputs, inputs);
    g.gradient = CompiledMap::build(grad, inputs);
    g.gradient_size = CompiledMap::build(sizes, inputs);
    return g;
}

}  // namespace pgi
