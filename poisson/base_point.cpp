#include "poisson/base_point.hpp"

#include <algorithm>

namespace pgi {

std::vector<std::vector<Poly>> base_point_series(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S,
                                                 std::size_t P) {
    const std::size_t n = M.dim(), N = P + 1, D = std::min(P, r.degree);
    // grad S_j and alpha - x = A_1 + ... + A_D, as polynomials
    std::vector<Poly> grads;  // grads[j * n + l] = d_l S_{j+1}
    for (const auto& Sj : S)
        for (std::size_t l = 0; l < n; ++l) grads.push_back(derivative(Sj, M.x(l)));
    std::vector<Poly> higher;
    for (std::size_t i = 0; i < n; ++i) higher.push_back(r.alpha[i].truncated(D + 1).sum() - M.x_gen(i));

    std::vector<Series> u(n, Series(M.ring(), N));
    for (std::size_t sweep = 0; sweep < P; ++sweep) {
        // y = x + u
        std::vector<std::optional<Series>> at_y(M.ring()->size());
        for (std::size_t l = 0; l < n; ++l) at_y[M.x(l)] = Series::constant(M.x_gen(l), N) + u[l];
        // grad S_t(y) = sum_j t^j grad S_j(y)
        auto g = compose(grads, at_y, N);
        std::vector<std::optional<Series>> at_y_p = at_y;
        for (std::size_t l = 0; l < n; ++l) {
            Series p(M.ring(), N);
            for (std::size_t j = 1; j <= S.size(); ++j)
                for (std::size_t m = j; m < N; ++m) p[m] += g[(j - 1) * n + l][m - j];
            at_y_p[M.p(l)] = std::move(p);
        }
        // u = -(alpha - id)(y, grad S_t(y))
        auto h = compose(higher, at_y_p, N);
        for (std::size_t l = 0; l < n; ++l) u[l] = Rational(-1) * h[l];
    }
    std::vector<std::vector<Poly>> out(P, std::vector<Poly>(n, Poly(M.ring())));
    for (std::size_t m = 1; m <= P; ++m)
        for (std::size_t l = 0; l < n; ++l) out[m - 1][l] = u[l][m];
    return out;
}

}  // namespace pgi
