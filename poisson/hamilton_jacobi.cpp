#include "poisson/hamilton_jacobi.hpp"

#include "series/composition.hpp"

#include <stdexcept>

namespace pgi {

std::vector<Poly> hamilton_jacobi_terms(const PhaseSpace& M, const Realisation& r, const Poly& H, std::size_t k,
                                        EvenTerms even) {
    if (k < 1) throw std::invalid_argument("hamilton_jacobi_terms: the order k must be at least 1");
    if (r.degree + 1 < k)
        throw std::invalid_argument("hamilton_jacobi_terms: order " + std::to_string(k) +
                                    " needs a realisation of p-degree " + std::to_string(k - 1) + ", got " +
                                    std::to_string(r.degree));
    // S_{i+1} = 1/(i+1) [t^i] G(x, grad S_t(x)) with G = H o alpha, graded by p-degree (docs/math.md 5): G's
    // part of p-degree d is O(t^d) along p = grad S_t = O(t), so [t^i] reads G_0..G_i and grad S_1..S_i only,
    // and the composition is completed one order per term, each product of gradients formed once. Composing
    // H with alpha once, before the gradients, replaces the composition of every alpha_l along the gradient
    // and then of H along those: one polynomial G_d where there were dim of them.
    std::vector<std::optional<Series>> alpha_images(M.ring()->size()), p_images(M.ring()->size());
    for (std::size_t l = 0; l < M.dim(); ++l) {
        alpha_images[M.x(l)] = r.alpha[l].truncated(k);  // x_l -> alpha_l, graded by p-degree
        p_images[M.p(l)] = Series(M.ring(), k);          // p_l -> sum_{j=1..i} t^j d_l S_j
    }
    // With a symmetric realisation S_t is odd in t (S_2j = 0), so p = grad S_t is odd and G_d(x, grad S_t) has the
    // parity of d: [t^i] reads only the G_d with d = i mod 2. The even terms and the odd G_d (which no odd term
    // reads) are then never composed; the products of gradients the odd terms need are formed all the same.
    const bool odd_in_t = even == EvenTerms::from_symmetry && is_symmetric(r);
    ComposeByOrder H_along_alpha({H}, std::move(alpha_images), k);  // G_d = [p-degree d] H(alpha)
    ComposeByOrder G_along_gradient(M.ring(), std::move(p_images), k);
    G_along_gradient.append(H_along_alpha.coefficient(0, 0));
    std::vector<Poly> S{H};
    for (std::size_t i = 1; i < k; ++i) {
        BudgetStage stage(M.ring()->budget(), "Hamilton-Jacobi term S_" + std::to_string(i + 1), i + 1,
                          k);                          // names refusals, progress
        const bool vanishes = odd_in_t && i % 2 == 1;  // S_(i+1) with i + 1 even
        // S_(i+1) is the first to read G_i (index i of G_along_gradient, a zero in its place when no term reads it)
        G_along_gradient.append(vanishes ? Poly(M.ring()) : H_along_alpha.coefficient(0, i));
        if (!S[i - 1].is_zero())
            for (std::size_t l = 0; l < M.dim(); ++l)
                G_along_gradient.set_image(M.p(l), i, derivative(S[i - 1], M.x(l)));
        if (vanishes) {
            S.emplace_back(M.ring());
            continue;
        }
        std::vector<Poly> parts;
        for (std::size_t d = odd_in_t ? i % 2 : 0; d <= i; d += odd_in_t ? 2 : 1)
            parts.push_back(G_along_gradient.coefficient(d, i));
        S.push_back(Rational(1, static_cast<unsigned long>(i + 1)) * sum(std::move(parts), M.ring()));
    }
    return S;
}

}  // namespace pgi
