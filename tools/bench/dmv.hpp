#pragma once
// The discrete Moser-Veselov (DMV) algorithm for the free rigid body m' = m x (I^-1 m), and its
// preprocessed versions of order 4..10 (Hairer and Vilmart, "Preprocessed discrete Moser-Veselov
// algorithm for the full dynamics of a rigid body", J. Phys. A 39 (2006) 13225-13235): DMV applied with
// modified moments of inertia, 1/I_i(h) = sigma(h)/I_i + delta(h), where sigma - 1 and delta are
// polynomials in h^2 |m|^2 / 2 and h^2 H(m) (H = sum m_i^2 / (2 I_i)) whose coefficients are rational
// functions of I_1, I_2, I_3 (the paper's formulas, checked by tests/bench_dmv.cpp's fitted orders).
// A peer for tools/bench/dmv_bench (issue 13), not part of the library: only the angular momentum is
// advanced (the attitude quaternion of the full DMV is not: pgi's rigid body scene has no attitude).
#include <array>
#include <cstddef>

namespace pgi::bench {

using Vec3 = std::array<double, 3>;

class Dmv {
public:
    /// order: 2 (plain DMV), 4, 6, 8 or 10 (preprocessed). inertia: I_1, I_2, I_3 > 0.
    Dmv(int order, const Vec3& inertia);

    int order() const { return order_; }

    /// One step of size h from m (in place). Throws std::runtime_error if the stage's fixed-point
    /// iteration does not converge to round-off (a step too large for the method).
    void step(Vec3& m, double h) const;

private:
    // the coefficients of sigma - 1 (s) and delta (d) at h^(2j), j = 1..order/2 - 1: the monomials
    // N^(j-i) E^i, i = 0..j, with N = h^2 |m|^2 / 2 and E = h^2 H(m)
    struct Layer {
        std::array<double, 5> s{}, d{};
    };
    int order_;
    Vec3 I_;
    std::array<Layer, 4> layers_{};
    void modified_inverse_inertia(const Vec3& m, double h, Vec3& a) const;
};

}  // namespace pgi::bench
