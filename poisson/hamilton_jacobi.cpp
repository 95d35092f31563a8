#include "poisson/hamilton_jacobi.hpp"

#include <stdexcept>

namespace pgi {

namespace {

// alpha_l(x, grad S_t^(i)(x)) as t-series O(t^{i+1}), from alpha truncated after p-degree i.
std::vector<Series> alpha_along_gradient(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S,
                                         std::size_t i) {
    const std::size_t N = i + 1;
    std::vector<std::optional<Series>> images(M.ring()->size());
    for (std::size_t l = 0; l < M.dim(); ++l) {
        // p_l -> sum_{j=1..i} t^j d_l S_j
        Series grad(M.ring(), N);
        for (std::size_t j = 1; j <= i; ++j) grad[j] = derivative(S[j - 1], M.x(l));
        images[M.p(l)] = std::move(grad);
    }
    std::vector<Poly> alpha;
    for (std::size_t l = 0; l < M.dim(); ++l) alpha.push_back(r.alpha[l].truncated(N).sum());
    return compose(alpha, images, N);
}

}  // namespace

std::vector<Poly> hamilton_jacobi_terms(const PhaseSpace& M, const Realisation& r, const Poly& H, std::size_t k) {
    if (k < 1) throw std::invalid_argument("hamilton_jacobi_terms: the order k must be at least 1");
    if (r.degree + 1 < k)
        throw std::invalid_argument("hamilton_jacobi_terms: order " + std::to_string(k) + " needs a realisation of p-degree " +
                                    std::to_string(k - 1) + ", got " + std::to_string(r.degree));
    std::vector<Poly> S{H};
    for (std::size_t i = 1; i < k; ++i) {
        BudgetStage stage(M.ring()->budget(), "Hamilton-Jacobi term S_" + std::to_string(i + 1), i + 1, k);  // names refusals, progress
        auto a = alpha_along_gradient(M, r, S, i);
        std::vector<std::optional<Series>> images(M.ring()->size());
        for (std::size_t l = 0; l < M.dim(); ++l) images[M.x(l)] = std::move(a[l]);
        // S_{i+1} = 1/(i+1) [t^i] H(alpha(x, grad S_t^(i)(x)))
        Series HoA = compose(H, images, i + 1);
        S.push_back(Rational(1, static_cast<unsigned long>(i + 1)) * HoA[i]);
    }
    return S;
}

}  // namespace pgi
