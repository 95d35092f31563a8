#include "poisson/detail/sparse_hessian.hpp"

#include "poisson/realisation_eval.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pgi {

namespace {

// The fewest m whose Hessian terms past S_m are negligible at the typical state (compile_gradient); hessians[j] holds
// Hess S_{j+1}'s entries r <= c, numbered as g.hessian_value numbers the pattern's, kept[e] whether the Newton matrix
// reads entry e (the others, in a passive row or column, move nothing it solves for: a parameter's, say).
std::size_t hessian_terms_needed(const PhaseSpace& M, const CompiledGradient& g,
                                 const std::vector<std::vector<Poly>>& hessians, const std::vector<bool>& kept,
                                 double dt, const HessianTruncation& t) {
    const std::vector<double> x = M.point(t.x_typical);
    // what S_j's Hessian terms move J by: alpha_p_size times their inf norm (a column sum: the matrix is symmetric)
    const SparsePattern& P = g.hessian;
    std::vector<double> size(hessians.size(), 0.0), value;
    for (std::size_t j = 0; j < hessians.size(); ++j) {
        value.clear();
        for (const Poly& h : hessians[j]) value.push_back(std::abs(evaluate(h, x)));
        for (std::size_t c = 0; c < P.cols; ++c) {
            double column = 0;
            for (int k = P.outer[c]; k < P.outer[c + 1]; ++k)
                if (const std::uint32_t e = g.hessian_value[std::size_t(k)]; kept[e]) column += value[e];
            size[j] = std::max(size[j], column);
        }
        size[j] *= t.alpha_p_size * std::pow(dt, double(j + 1));
    }
    double tail = 0;
    std::size_t m = hessians.size();
    while (m > 1 && tail + size[m - 1] <= t.bound) tail += size[--m];  // (a NaN size is never neglected)
    return m;
}

}  // namespace

CompiledGradient compile_gradient(const PhaseSpace& M, const std::vector<Poly>& S, double planned_dt,
                                  const HessianTruncation& truncation, const std::vector<bool>& passive) {
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
    const auto is_passive = [&](std::size_t i) { return i < passive.size() && passive[i]; };
    std::vector<std::vector<Poly>> hessians(S.size());
    std::vector<bool> kept;  // the Newton matrix reads entry r <= c (numbered as hessians[j]): neither is passive
    for (std::size_t c = 0; c < n; ++c)
        for (int k = P.outer[c]; k < P.outer[c + 1]; ++k)
            if (const auto r = std::size_t(P.inner[std::size_t(k)]); r <= c)
                kept.push_back(!is_passive(r) && !is_passive(c));
    for (std::size_t j = 0; j < S.size(); ++j)
        for (std::size_t c = 0; c < n; ++c)
            for (int k = P.outer[c]; k < P.outer[c + 1]; ++k)
                if (const auto r = std::size_t(P.inner[std::size_t(k)]); r <= c)
                    hessians[j].push_back(derivative(grad[j][c], M.x(r)));
    g.hessian_terms = S.size();
    if (!truncation.x_typical.empty() && n <= hessian_truncation_dim && planned_dt > 0 && truncation.bound > 0)
        g.hessian_terms = hessian_terms_needed(M, g, hessians, kept, planned_dt, truncation);
    const auto inputs = M.coordinate_vars();
    const Poly zero(M.ring());
    std::vector<std::vector<Poly>> newton_grad(S.size());  // grad S_j without the passive components
    for (std::size_t j = 0; j < S.size(); ++j) {
        for (std::size_t l = 0; l < n; ++l) newton_grad[j].push_back(is_passive(l) ? zero : grad[j][l]);
        with_hessian[j] = newton_grad[j];
        for (std::size_t e = 0; e < hessians[j].size(); ++e)
            with_hessian[j].push_back(j < g.hessian_terms && kept[e] ? hessians[j][e] : zero);
    }
    const bool all_kept = std::all_of(kept.begin(), kept.end(), [](bool k) { return k; });
    // the passive coordinates that end the list (a scheme's parameters) are read through the coefficients
    std::size_t slow = 0;
    while (slow < n && is_passive(n - 1 - slow)) ++slow;
    if (g.hessian_terms < S.size() || !all_kept)
        g.full_hessian = DtSeriesMap::build(hessians, inputs, planned_dt, slow);
    g.with_hessian = DtSeriesMap::build(with_hessian, inputs, planned_dt, slow);
    g.gradient = DtSeriesMap::build(newton_grad, inputs, planned_dt, slow);
    g.gradient_size = DtSeriesMap::build(sizes, inputs, 0, slow);  // read at |x| and |dt|: no planned sum
    return g;
}

void expand_hessian(const CompiledGradient& g, const double* upper, double* values) {
    for (std::size_t k = 0; k < g.hessian_value.size(); ++k) values[k] = upper[g.hessian_value[k]];
}

}  // namespace pgi
