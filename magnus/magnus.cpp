#include "magnus/magnus.hpp"

namespace pgi {

Series poisson_bracket(const PoissonStructure& pi, const Series& A, const Series& B) {
    const std::size_t N = std::min(A.order(), B.order());
    Series r(A.ring(), N);
    for (std::size_t a = 0; a < N; ++a) {
        if (A[a].is_zero()) continue;
        for (std::size_t b = 0; a + b < N; ++b)
            if (!B[b].is_zero()) r[a + b] += pi.bracket(A[a], B[b]);
    }
    return r;
}

Series magnus_series(const PoissonStructure& pi, const Series& h, std::size_t m) {
    Series M(h.ring(), m + 1);
    for (std::size_t j = 1; j <= m; ++j) {
        BudgetStage stage(h.ring()->budget(), "Magnus series, term M_" + std::to_string(j), j,
                          m);  // names refusals, progress
        // [e^{j-1}] of sum_{i<j} B_i/i! ad_M^i h: ad_M raises the order by one, so M_1..M_{j-1} suffice
        Series hj(h.ring(), j);
        for (std::size_t d = 0; d < std::min(j, h.order()); ++d) hj[d] = h[d];
        Series Mj = M.truncated(j);
        Series term = hj, rhs = hj;
        for (std::size_t i = 1; i < j; ++i) {
            term = poisson_bracket(pi, Mj, term);
            const Rational c = bernoulli(i) * inverse_factorial(i);
            if (!c.is_zero()) rhs += c * term;
        }
        // dM/de = sum_j j M_j e^{j-1}
        M[j] = Rational(1, static_cast<unsigned long>(j)) * rhs[j - 1];
    }
    return M;
}

}  // namespace pgi
