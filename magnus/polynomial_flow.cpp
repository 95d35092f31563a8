#include "magnus/polynomial_flow.hpp"

#include <algorithm>

namespace pgi {

std::optional<PolynomialFlow> PolynomialFlow::build(const PoissonStructure& pi, const Poly& H, std::size_t max_K) {
    const PhaseSpace& M = pi.phase_space();
    std::vector<Poly> level, terms;
    for (std::size_t i = 0; i < M.dim(); ++i) level.push_back(M.x_gen(i));
    for (std::size_t K = 1; K <= max_K; ++K) {
        for (auto& f : level) f = pi.bracket(f, H);  // L^K x
        if (std::all_of(level.begin(), level.end(), [](const Poly& f) { return f.is_zero(); }))
            return PolynomialFlow(CompiledMap::build(terms, M.coordinate_vars()), M.dim(), K);
        terms.insert(terms.end(), level.begin(), level.end());
    }
    return std::nullopt;
}

void PolynomialFlow::apply(double t, std::vector<double>& x) const {
    out_.resize(terms_.num_outputs());
    if (out_.empty()) return;  // L x = 0: H's flow is the identity
    terms_.eval(x.data(), out_.data());
    double c = 1;
    for (std::size_t k = 1; k < K_; ++k) {
        c *= t / double(k);
        for (std::size_t i = 0; i < n_; ++i) x[i] += c * out_[(k - 1) * n_ + i];
    }
}

void splitting_step(SplittingMethod method, const PolynomialFlow& A, const PolynomialFlow& B, double dt,
                    std::vector<double>& x) {
    auto strang = [&](double h) {
        A.apply(h / 2, x);
        B.apply(h, x);
        A.apply(h / 2, x);
    };
    switch (method) {
        case SplittingMethod::lie_trotter:
            A.apply(dt, x);
            B.apply(dt, x);
            return;
        case SplittingMethod::strang:
            strang(dt);
            return;
        case SplittingMethod::yoshida: {
            const double w = yoshida_weight();
            strang(w * dt);
            strang((1 - 2 * w) * dt);
            strang(w * dt);
            return;
        }
    }
}

}  // namespace pgi
