#pragma once
// Variation functions of the Hamilton-Jacobi scheme and its modified Hamiltonian (docs/math.md 7).
#include "poisson/realisation.hpp"

#include <vector>

namespace pgi {

/// Set the result to h_t = (d/dt S_t) o Phi_t^{-1} + O(t^N), Phi_t(x) = beta(x, grad S_t(x)), S_t = sum_j t^j S[j-1]:
/// the time-dependent Hamiltonian whose time-t flow is the step of size t. Reads beta through p-degree N - 1.
Series variation_functions(const PhaseSpace& M, const Realisation& r, const std::vector<Poly>& S, std::size_t N);

/// Set the result to H_0..H_m (H_0 = H) with Htilde(dt) = sum_j dt^j H_j = M_dt / dt the modified Hamiltonian
/// of the order-k scheme built on the realisation choice: its time-dt flow agrees with one step to the
/// truncation order. Unique modulo Casimirs. Requires k >= 1 and pi to satisfy Jacobi.
std::vector<Poly> modified_hamiltonian(const PoissonStructure& pi, const Poly& H, std::size_t k,
                                       RealisationChoice choice, std::size_t m);
/// The same from a realisation r of pi through p-degree m at least and the scheme's S_1..S_k
/// (std::invalid_argument if r is shallower): what a Scheme, which already holds both, calls.
std::vector<Poly> modified_hamiltonian(const PoissonStructure& pi, const Realisation& r, const std::vector<Poly>& S,
                                       std::size_t m);

}  // namespace pgi
