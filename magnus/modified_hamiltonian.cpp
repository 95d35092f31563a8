#include "magnus/modified_hamiltonian.hpp"

#include "magnus/magnus.hpp"
#include "poisson/detail/bisection.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "series/composition.hpp"

#include <stdexcept>

namespace pgi {

Series variation_functions(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S, std::size_t N) {
    // Phi_t^{-1} = id + v
    auto v = inverse_near_identity(bisection_displacement(M, r, Side::beta, S, N), M.coordinate_vars(), N);
    std::vector<std::optional<Series>> images(M.ring()->size());
    for (std::size_t i = 0; i < M.dim(); ++i) images[M.x(i)] = Series::constant(M.x_gen(i), N) + v[i];
    // d/dt S_t = sum_j j t^{j-1} S_j
    Series dS(M.ring(), N);
    for (std::size_t j = 1; j <= S.size() && j <= N; ++j) dS[j - 1] = Rational(static_cast<long>(j)) * S[j - 1];
    return compose(std::vector<Series>{dS}, images, N).front();
}

std::vector<Poly> modified_hamiltonian(const PoissonStructure& pi, const Poly& H, std::size_t k,
                                       RealisationChoice choice, std::size_t m) {
    if (k < 1) throw std::invalid_argument("modified_hamiltonian: the order k must be at least 1");
    const PhaseSpace& M = pi.phase_space();
    BudgetStage stage(M.ring()->budget(), "modified Hamiltonian through dt^" + std::to_string(m), 0, 0);
    // h through t^m needs beta through p-degree m, and S_1..S_k need alpha through degree k - 1
    Realisation r = build_realisation(pi, choice, std::max(m, realisation_degree_for_order(k)));
    return modified_hamiltonian(pi, r, hamilton_jacobi_terms(M, r, H, k), m);
}

std::vector<Poly> modified_hamiltonian(const PoissonStructure& pi, const Realisation& r, const std::vector<Poly>& S,
                                       std::size_t m) {
    if (r.degree < m)
        throw std::invalid_argument("modified_hamiltonian: H_" + std::to_string(m) + " needs beta through p-degree " +
                                    std::to_string(m) + ", the realisation has " + std::to_string(r.degree));
    const PhaseSpace& M = pi.phase_space();
    Series h = variation_functions(M, r, S, m + 1);
    Series Me = magnus_series(pi, h, m + 1);
    // Htilde = M_dt / dt: H_j = M_{j+1}
    std::vector<Poly> Ht;
    for (std::size_t j = 0; j <= m; ++j) Ht.push_back(Me[j + 1]);
    return Ht;
}

}  // namespace pgi
