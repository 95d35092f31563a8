#include "poisson/hamilton_jacobi.hpp"

#include "series/composition.hpp"

#include <stdexcept>

namespace pgi {

namespace {

// alpha_l's part of p-degree d at l * k + d, d < k (the higher degrees are O(t^k)).
std::vector<Poly> graded_parts(const Realisation& r, std::size_t k) {
    std::vector<Poly> parts;
    for (const Series& a : r.alpha)
        for (std::size_t d = 0; d < k; ++d) parts.push_back(a[d]);
    return parts;
}

}  // namespace

std::vector<Poly> hamilton_jacobi_terms(const PhaseSpace& M, const Realisation& r, const Poly& H, std::size_t k) {
    if (k < 1) throw std::invalid_argument("hamilton_jacobi_terms: the order k must be at least 1");
    if (r.degree + 1 < k)
        throw std::invalid_argument("hamilton_jacobi_terms: order " + std::to_string(k) + " needs a realisation of p-degree " +
                                    std::to_string(k - 1) + ", got " + std::to_string(r.degree));
    // S_{i+1} = 1/(i+1) [t^i] H(alpha(x, grad S_t(x))), S_t = sum_j t^j S_j: [t^i] alpha(x, grad S_t) reads
    // grad S_1..S_i only (p = O(t)), and [t^i] H(alpha) reads alpha's orders 0..i, so both compositions are
    // completed one order per term (docs/math.md 5) and each of their products is formed once.
    std::vector<std::optional<Series>> p_images(M.ring()->size()), x_images(M.ring()->size());
    for (std::size_t l = 0; l < M.dim(); ++l) {
        p_images[M.p(l)] = Series(M.ring(), k);  // p_l -> sum_{j=1..i} t^j d_l S_j
        x_images[M.x(l)] = Series(M.ring(), k);  // x_l -> alpha_l(x, grad S_t)
    }
    ComposeByOrder alpha_along_gradient(graded_parts(r, k), std::move(p_images), k);
    // [t^i] alpha_l(x, grad S_t): the part of p-degree d is O(t^d)
    auto alpha_coefficient = [&](std::size_t l, std::size_t i) {
        std::vector<Poly> parts;
        for (std::size_t d = 0; d <= i; ++d) parts.push_back(alpha_along_gradient.coefficient(l * k + d, i));
        return sum(std::move(parts), M.ring());
    };
    ComposeByOrder H_along_alpha({H}, std::move(x_images), k);
    for (std::size_t l = 0; l < M.dim(); ++l) H_along_alpha.set_image(M.x(l), 0, alpha_coefficient(l, 0));
    std::vector<Poly> S{H};
    for (std::size_t i = 1; i < k; ++i) {
        BudgetStage stage(M.ring()->budget(), "Hamilton-Jacobi term S_" + std::to_string(i + 1), i + 1, k);  // names refusals, progress
        for (std::size_t l = 0; l < M.dim(); ++l) alpha_along_gradient.set_image(M.p(l), i, derivative(S[i - 1], M.x(l)));
        for (std::size_t l = 0; l < M.dim(); ++l) H_along_alpha.set_image(M.x(l), i, alpha_coefficient(l, i));
        S.push_back(Rational(1, static_cast<unsigned long>(i + 1)) * H_along_alpha.coefficient(0, i));
    }
    return S;
}

}  // namespace pgi
