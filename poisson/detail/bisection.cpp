#include "poisson/detail/bisection.hpp"

#include "series/composition.hpp"

#include <algorithm>

namespace pgi {

std::vector<Series> bisection_displacement(const PhaseSpace& M, const Realisation& r, Side side,
                                           const std::vector<Poly>& S, std::size_t N) {
    const std::size_t n = M.dim(), D = std::min(N - 1, r.degree);
    // p_l -> sum_j t^j d_l S_j
    std::vector<std::optional<Series>> images(M.ring()->size());
    for (std::size_t l = 0; l < n; ++l) {
        Series grad(M.ring(), N);
        for (std::size_t j = 1; j <= S.size() && j < N; ++j) grad[j] = derivative(S[j - 1], M.x(l));
        images[M.p(l)] = std::move(grad);
    }
    const auto& map = side == Side::alpha ? r.alpha : r.beta;
    std::vector<Poly> displacement;
    for (std::size_t i = 0; i < n; ++i) displacement.push_back(map[i].truncated(D + 1).sum() - M.x_gen(i));
    return compose(displacement, images, N);
}

std::vector<std::vector<Poly>> base_point_series(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S,
                                                 std::size_t P,
                                                 const std::function<bool(const std::vector<Series>&)>& enough) {
    const std::size_t n = M.dim();
    auto v =
        inverse_near_identity(bisection_displacement(M, r, Side::alpha, S, P + 1), M.coordinate_vars(), P + 1, enough);
    const std::size_t orders = v.empty() ? 0 : v.front().order() - 1;
    std::vector<std::vector<Poly>> out(orders, std::vector<Poly>(n, Poly(M.ring())));
    for (std::size_t m = 1; m <= orders; ++m)
        for (std::size_t l = 0; l < n; ++l) out[m - 1][l] = v[l][m];
    return out;
}

}  // namespace pgi
