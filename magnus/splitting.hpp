#pragma once
// Modified Hamiltonians of splitting methods for H = H_A + H_B: the Baker-Campbell-Hausdorff series in
// Poisson brackets, exact over Q (Lie-Trotter, Strang) or over Q(w), w = 1/(2 - 2^{1/3}) (Yoshida).
#include "poisson/structure.hpp"

#include <string>
#include <vector>

namespace pgi {

/// One step of size dt: lie_trotter = flow of H_A for dt, then of H_B for dt; strang = H_A for dt/2,
/// H_B for dt, H_A for dt/2; yoshida = strang(w dt) strang((1 - 2w) dt) strang(w dt), w = 1/(2 - 2^{1/3}).
enum class SplittingMethod { lie_trotter, strang, yoshida };

/// "lie-trotter", "strang", "yoshida"; parse throws std::invalid_argument naming the choices.
SplittingMethod parse_splitting_method(const std::string& name);
std::string to_string(SplittingMethod method);
/// 1, 2, 4.
std::size_t method_order(SplittingMethod method);

/// Z with phi^Z_1 = phi^Y_1 o phi^X_1 (the flow of X first) in the flow convention of docs/math.md 1, for
/// X, Y = O(e) series in e with polynomial coefficients: Z = X + Y + (1/2){Y, X} + ... + O(e^N), the
/// solution at s = 1 of dZ/ds = sum_i B_i/i! ad_Z^i Y, Z(0) = X (the Magnus equation of magnus_series).
Series compose_flows(const PoissonStructure& pi, const Series& X, const Series& Y, std::size_t N);

/// Htilde = sum_j dt^j H_j of a splitting method, each H_j = sum_c w^c H[j][c] on the basis 1, w, w^2
/// (one component, c = 0, for the methods over Q). The flow of Htilde for dt is one step to O(dt^{m+2}).
struct SplittingModified {
    SplittingMethod method;
    std::vector<std::vector<Poly>> H;  // H[j][c], j = 0..m
    /// sum_j dt^j H_j(x) in double (w in double for Yoshida).
    double evaluate(const std::vector<double>& x, double dt) const;
};

/// The weight w of Yoshida's composition, 1/(2 - 2^{1/3}): the real root of 6w^3 - 12w^2 + 6w - 1.
double yoshida_weight();

/// H_0..H_m of the splitting method applied to H = A + B (A, B polynomials in the coordinates).
SplittingModified splitting_modified_hamiltonian(const PoissonStructure& pi, const Poly& A, const Poly& B,
                                                 SplittingMethod method, std::size_t m);

}  // namespace pgi
