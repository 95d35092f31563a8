#include "tools/bench/dmv.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pgi::bench {

namespace {

// Symmetric functions of the moments of inertia that the coefficients are written in.
struct Inertia {
    double D;                             // I_1 I_2 I_3
    double S1, S2, S3, S4;                // sum I_i^p
    double X1, X2, X3, X4;                // sum I_i^-p
    double P11, P12, P21, P13, P31, P22;  // P_pq = sum over i of (I_j^p + I_k^p) / I_i^q, {i, j, k} = {1, 2, 3}

    explicit Inertia(const Vec3& I) : D(I[0] * I[1] * I[2]) {
        auto pw = [&](int p) { return std::pow(I[0], p) + std::pow(I[1], p) + std::pow(I[2], p); };
        S1 = pw(1), S2 = pw(2), S3 = pw(3), S4 = pw(4);
        X1 = pw(-1), X2 = pw(-2), X3 = pw(-3), X4 = pw(-4);
        auto P = [&](int p, int q) {
            double s = 0;
            for (int i = 0; i < 3; ++i)
                s += (std::pow(I[(i + 1) % 3], p) + std::pow(I[(i + 2) % 3], p)) / std::pow(I[i], q);
            return s;
        };
        P11 = P(1, 1), P12 = P(1, 2), P21 = P(2, 1), P13 = P(1, 3), P31 = P(3, 1), P22 = P(2, 2);
    }
};

}  // namespace

Dmv::Dmv(int order, const Vec3& inertia) : order_(order), I_(inertia) {
    if (order < 2 || order > 10 || order % 2 != 0)
        throw std::invalid_argument("DMV: order must be 2, 4, 6, 8 or 10, not " + std::to_string(order));
    for (double v : inertia)
        if (!(v > 0) || !std::isfinite(v))
            throw std::invalid_argument("DMV: moments of inertia must be positive and finite");
    const Inertia c(inertia);
    const double D = c.D, D2 = D * D, D3 = D2 * D, D4 = D2 * D2;
    // Hairer and Vilmart (2006), the modified moments of inertia through h^8: layer j holds the
    // coefficients of N^(j+1-i) E^i, i = 0..j+1, in sigma - 1 (s) and in delta (d).
    layers_[0].s = {c.S1 / (6 * D), -c.X1 / 3};
    layers_[0].d = {-1 / (3 * D), c.S1 / (6 * D)};
    layers_[1].s = {(c.S2 / D - c.X1) / (30 * D), (1 - c.P11) / (30 * D), (3 * c.S1 / D + 2 * c.X2) / 60};
    layers_[1].d = {-c.S1 / D2 / 60, c.X1 / D / 10 - c.S2 / D2 / 60, -(9 + c.P11) / D / 60};
    layers_[2].s = {(4 * D + 17 * c.S3 - 15 * D * c.P11) / (2520 * D3),
                    (9 * c.S1 + 10 * D * c.X2 - 6 * c.P21) / (420 * D2),
                    ((6 * c.P12 - 100 * c.X1) * D + 53 * c.S2) / (2520 * D2), (15 - D * c.X3 - 2 * c.P11) / (630 * D)};
    layers_[2].d = {(34 * D * c.X1 - 19 * c.S2) / (2520 * D3), (c.S3 + 2 * D * c.P11 - 85 * D) / (1260 * D3),
                    (47 * c.S1 + 13 * c.P21 - 38 * D * c.X2) / (2520 * D2),
                    (9 * D * c.X1 + D * c.P12 - 11 * c.S2) / (1260 * D2)};
    layers_[3].s = {(62 * c.S4 - 94 * D * c.P21 + 66 * D2 * c.X2 + 81 * D * c.S1) / (45360 * D4),
                    (-77 * c.P31 + 75 * D * c.P12 + 214 * c.S2 - 240 * D * c.X1) / (22680 * D3),
                    (26 * D * c.P22 + 55 * c.S3 + 204 * D - 50 * D2 * c.X3 - 59 * D * c.P11) / (7560 * D3),
                    (137 * D * c.X2 - D * c.P13 + 3 * c.S1 - 69 * c.P21) / (11340 * D2),
                    (2 * D2 * c.X4 + 5 * D * c.P12 - 171 * D * c.X1 + 159 * c.S2) / (45360 * D2)};
    layers_[3].d = {(60 * c.P11 * D - 61 * c.S3 - 247 * D) / (45360 * D4),
                    (54 * D * c.S1 - c.S4 + 218 * D * c.P21 - 426 * D2 * c.X2) / (45360 * D4),
                    (125 * D * c.X1 - 5 * c.P31 - 130 * c.S2 + 4 * D * c.P12) / (7560 * D3),
                    (67 * c.S3 - 735 * D - 15 * D * c.P22 + 87 * D * c.P11 + 34 * D2 * c.X3) / (22680 * D3),
                    (165 * c.S1 - D * c.P13 - 9 * c.P21 - 145 * D * c.X2) / (45360 * D2)};
}

void Dmv::modified_inverse_inertia(const Vec3& m, double h, Vec3& a) const {
    const double h2 = h * h;
    const double N = 0.5 * h2 * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    const double E = 0.5 * h2 * (m[0] * m[0] / I_[0] + m[1] * m[1] / I_[1] + m[2] * m[2] / I_[2]);
    std::array<double, 5> Np{1, N, N * N, N * N * N, N * N * N * N}, Ep{1, E, E * E, E * E * E, E * E * E * E};
    double sigma = 1, delta = 0;
    for (int j = 0; j < order_ / 2 - 1; ++j) {
        const int deg = j + 1;  // the layer's monomials N^(deg-i) E^i
        for (int i = 0; i <= deg; ++i) {
            const double mono = Np[deg - i] * Ep[i];
            sigma += layers_[j].s[i] * mono;
            delta += layers_[j].d[i] * mono;
        }
    }
    for (int i = 0; i < 3; ++i) a[i] = sigma / I_[i] + delta;
}

void Dmv::step(Vec3& m, double h) const {
    Vec3 a;
    modified_inverse_inertia(m, h, a);
    const Vec3 J{1 / a[0], 1 / a[1], 1 / a[2]};  // the modified moments of inertia
    Vec3 b, f, c;
    for (int i = 0; i < 3; ++i) {
        const int j = (i + 1) % 3, k = (i + 2) % 3;
        b[i] = 0.5 * h * a[i] * m[i];
        f[i] = (J[j] - J[k]) * a[i];
    }
    // the stage: c = (1 + |c|^2) b + f o (c_j c_k), by Gauss-Seidel sweeps from c = b: a contraction of
    // factor q ~ |c|^2 ~ (h |m| / I)^2, so once a sweep changes c by less than 1e-14 |c| the error left is
    // q 1e-14 |c|, below round-off for q < 0.01 (the sweeps themselves stall at a few ulps, so the test
    // cannot ask for less)
    c = b;
    const double tol = 1e-14;
    int sweeps = 0;
    for (double change = INFINITY; !(change <= tol * (std::abs(c[0]) + std::abs(c[1]) + std::abs(c[2]))); ++sweeps) {
        if (sweeps == 60 || (sweeps > 0 && !std::isfinite(change)))
            throw std::runtime_error("DMV: the stage did not converge to round-off (step " + std::to_string(h) +
                                     " too large)");
        const double alpha = 1 + c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        change = 0;
        for (int i = 0; i < 3; ++i) {
            const double next = alpha * b[i] + f[i] * c[(i + 1) % 3] * c[(i + 2) % 3];
            change += std::abs(next - c[i]);
            c[i] = next;
        }
    }
    const double scale = 4 / (h * (1 + c[0] * c[0] + c[1] * c[1] + c[2] * c[2]));
    for (int i = 0; i < 3; ++i) m[i] += scale * (J[(i + 1) % 3] - J[(i + 2) % 3]) * c[(i + 1) % 3] * c[(i + 2) % 3];
}

}  // namespace pgi::bench
