#pragma once
// Exact flows of Hamiltonians whose vector field is nilpotent (kicks and drifts), and the splitting step
// built from two of them.
#include "magnus/splitting.hpp"
#include "series/compile.hpp"

#include <optional>

namespace pgi {

/// The time-t flow of H, exact, when L f = {f, H} (docs/math.md 1: xdot = {x, H}) is nilpotent on the
/// coordinates, L^K x_i = 0 for all i: then x(t) = sum_{k<K} t^k/k! (L^k x)(x(0)), a polynomial in t.
/// This covers a kick (H_A(q) on a canonical structure: K = 2) and a drift (H_B(p): K = 2).
class PolynomialFlow {
public:
    /// nullopt when L^K x != 0 for every K <= max_K (the flow is not polynomial of that degree).
    static std::optional<PolynomialFlow> build(const PoissonStructure& pi, const Poly& H, std::size_t max_K = 8);
    /// x <- x(t).
    void apply(double t, std::vector<double>& x) const;
    /// K: L^K x = 0.
    std::size_t nilpotency() const { return K_; }

private:
    PolynomialFlow(CompiledMap terms, std::size_t n, std::size_t K) : terms_(std::move(terms)), n_(n), K_(K) {}
    CompiledMap terms_;  // output (k - 1) n + i: L^k x_i, k = 1..K-1
    std::size_t n_, K_;
    mutable std::vector<double> out_;
};

/// One step of size dt of the splitting method, from exact flows of H_A and H_B (see SplittingMethod).
void splitting_step(SplittingMethod method, const PolynomialFlow& A, const PolynomialFlow& B, double dt,
                    std::vector<double>& x);

}  // namespace pgi
