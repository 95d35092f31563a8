// The log-canonical closed form (docs/math.md 3), written once over T (double, or a Pack of lanes): its values and
// derivatives (RealisationEvaluator::log_canonical_derivatives) and the acceptance test's values and term sizes
// (log_canonical_check), read by the dense and sparse paths (realisation_eval.cpp, realisation_eval_sparse.cpp)
// and by the lane step (realisation_lanes.ipp). Its helper has internal linkage on purpose: each including file
// keeps its own copy, compiled for its target (lane_step_avx2.cpp is built for AVX2).
#pragma once
#include "poisson/lanes.hpp"
#include "poisson/realisation_eval.hpp"

#include <cmath>

namespace pgi {

namespace {

// e^v - 1 lane by lane: the same libm call whatever T.
[[gnu::noinline]] [[maybe_unused]] double expm1_lane(double v) {
    return std::expm1(v);
}
template <class T>
PGI_LANE_INLINE T expm1_lanes(const T& v) {
    if constexpr (std::is_same_v<T, double>) {
        return expm1_lane(v);
    } else {
        T r;
        for (std::size_t w = 0; w < lanes::width; ++w) lanes::set_lane(r, w, expm1_lane(lanes::lane(v, w)));
        return r;
    }
}

// e^{u/2} - 1 from an exponent u0 nearby with em1_0 = e^{u0/2} - 1: (1 + em1_0) e^d - 1 = em1_0 + (1 + em1_0) expm1(d),
// d = (u - u0) / 2, expm1(d) by its cubic where |d| <= 2^-20 (the next term, d^4 / 24, is below 2^-84); lanes farther
// away call expm1. The result errs by a few ulps of em1_0, not of em1: where em1 is far smaller than em1_0 that is
// still below 2^-70 absolutely, far under the round-off of x + delta.
template <class T>
PGI_LANE_INLINE T expm1_near(const T& u, const T& u0, const T& em1_0) {
    const T d = 0.5 * (u - u0);
    const auto near = lanes::abs(d) <= 0x1p-20;
    T em1 = em1_0 + (1.0 + em1_0) * (d + d * d * (0.5 + d * (1.0 / 6)));
    if (!lanes::all(near)) em1 = lanes::select(near, em1, expm1_lanes(0.5 * u));
    return em1;
}

}  // namespace

// u_j = (1/2) sum_l a_lj x_l p_l; alpha_j = x_j e^{u_j}; delta_j = x_j (e^{-u_j} - e^{u_j}) = -2 x_j sinh u_j, and the
// derivatives on the structure's pattern: du_j/dx_l = a_lj p_l / 2, du_j/dp_l = a_lj x_l / 2. put(k, j, ...) receives
// entry k of a_pattern_ (column j), put.diagonal(j, ...) the terms of d/dx_j of alpha_j and delta_j; exponent and em1,
// if given, u_j and e^{u_j/2} - 1 (for log_canonical_check near this point).
template <class T, class Put>
void RealisationEvaluator::log_canonical_derivatives(const T* x, const T* p, T* alpha, T* delta, Put put, T* exponent,
                                                     T* em1_at, std::size_t count) const {
    for (std::size_t j = 0; j < (count < n_ ? count : n_); ++j) {
        T u{};
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            u = u + a_values_[std::size_t(k)] * x[l] * p[l];
        }
        // one transcendental: e^u - 1 keeps sinh u accurate for small u
        const T em1 = expm1_lanes(0.5 * u), e = 1.0 + em1;
        if (exponent) exponent[j] = u, em1_at[j] = em1;
        const T s = -(em1 + em1 / e), c = -(e + 1.0 / e);  // -2 sinh u, -2 cosh u
        alpha[j] = x[j] * e;
        delta[j] = x[j] * s;
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            const double half = 0.5 * a_values_[std::size_t(k)];
            const T ux = half * p[l], up = half * x[l];
            put(std::size_t(k), j, std::size_t(l), x[j] * e * ux, x[j] * e * up, x[j] * c * ux, x[j] * c * up);
        }
        put.diagonal(j, e, s);
    }
}

// delta alone, as log_canonical_check writes it.
template <class T>
void RealisationEvaluator::log_canonical_delta(const T* x, const T* p, T* delta, const T* exponent_near,
                                               const T* em1_near, std::size_t count) const {
    for (std::size_t j = 0; j < (count < n_ ? count : n_); ++j) {
        T u{};
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            u = u + a_values_[std::size_t(k)] * x[l] * p[l];
        }
        const T em1 = exponent_near ? expm1_near(u, exponent_near[j], em1_near[j]) : expm1_lanes(0.5 * u),
                e = 1.0 + em1;
        delta[j] = x[j] * -(em1 + em1 / e);
    }
}

// alpha and delta (where delta is not null) as above, and the size of each alpha_j's terms: the rounding of u_j
// (relative to the sum w_j of its terms' sizes) enters alpha_j multiplied by |alpha_j|; shift_j = alpha_j - x_j = x_j
// (e^{u_j/2} - 1). With exponent_near and em1_near (a derivatives evaluation's, the Newton iterate this one corrects by
// a small step), e^{u_j/2} - 1 is taken from them (expm1_near): the acceptance test after a converged Newton correction
// then calls no exponential.
template <class T>
void RealisationEvaluator::log_canonical_check(const T* x, const T* p, T* alpha, T* delta, T* size, T* shift,
                                               const T* exponent_near, const T* em1_near, std::size_t count) const {
    for (std::size_t j = 0; j < (count < n_ ? count : n_); ++j) {
        T u{}, w{};
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            const T term = a_values_[std::size_t(k)] * x[l] * p[l];
            u = u + term, w = w + lanes::abs(term);
        }
        const T em1 = exponent_near ? expm1_near(u, exponent_near[j], em1_near[j]) : expm1_lanes(0.5 * u),
                e = 1.0 + em1;
        alpha[j] = x[j] * e;
        shift[j] = x[j] * em1;
        if (delta) delta[j] = x[j] * -(em1 + em1 / e);
        size[j] = lanes::abs(x[j]) + lanes::abs(alpha[j]) * (1.0 + 0.5 * w);
    }
}

}  // namespace pgi
