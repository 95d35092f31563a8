// The realisation's forms the Newton step evaluates over lanes (poisson/lanes.hpp): the so(3) closed form and
// the compiled polynomial form, written once over T (double: one state; a Pack: lanes::width states), so the
// batch step's lanes carry the single step's bits. Included, and instantiated (PGI_REALISATION_LANES), by
// lane_step.cpp and lane_step_avx2.cpp; its helpers have internal linkage on purpose (one copy per target).
#pragma once
#include "poisson/lanes.hpp"
#include "poisson/log_canonical.ipp"
#include "poisson/realisation_eval.hpp"
#include "series/compile_lanes.ipp"

#include <algorithm>
#include <cmath>

namespace pgi {

namespace {

// The compiled map at one state (eval) or at lanes::width (structure of arrays: a Pack array is input v of lane w
// at v width + w) by the lane kernel compiled in this file, what eval_batch runs on one block: each lane eval's
// bits. scratch is sized by RealisationEvaluator::lane_scratch (in the baseline library).
[[maybe_unused]] void eval_map(const CompiledMap& map, const double* in, double* out, std::vector<double>&) {
    map.eval(in, out);
}
template <std::size_t P>
void eval_map(const CompiledMap& map, const lanes::PackOf<P>* in, lanes::PackOf<P>* out, std::vector<double>& scratch) {
    eval_tape_lanes<lanes::width>(map.tape(), reinterpret_cast<const double*>(in), lanes::width,
                                  reinterpret_cast<double*>(out), lanes::width, scratch.data());
}

// h(s) = (1 - (t/2) cot(t/2)) / s, s = t^2, and dh/ds in closed form: for s > 4, where the series below is slow.
// One lane at a time, the same libm calls in both instantiations.
[[gnu::noinline]] void rotation_closed(double s, double& h, double& dh) {
    const double t = std::sqrt(s), half = t / 2, sine = std::sin(half), cot = std::cos(half) / sine;
    const double q = half * cot, dq_dt = cot / 2 - half / (2 * sine * sine);
    h = (1 - q) / s;
    dh = (-dq_dt / (2 * t) - h) / s;
}

// Estrin's levels: q[0..M) -> q[2j] + q[2j+1] power (an odd last one kept), then with power^2, until one is left.
template <std::size_t M, class T>
PGI_LANE_INLINE T estrin_levels(const T* q, const T& power) {
    if constexpr (M == 1) {
        return q[0];
    } else {
        T r[(M + 1) / 2];
        for (std::size_t j = 0; j < M / 2; ++j) r[j] = q[2 * j + 1] * power + q[2 * j];
        if constexpr (M % 2 == 1) r[M / 2] = q[M - 1];
        return estrin_levels<(M + 1) / 2>(r, power * power);
    }
}

// sum_{j<J} c[j] u^j by Estrin's scheme: pairs c[j] + c[j+1] u, then pairs of those with u^2, u^4, ... A
// depth of about 2 log2 J multiply-adds, where Horner's is J: h(s) is a chain of ten (twenty) otherwise, the
// longest latency of the so(3) step, which has nothing else to overlap it with. J is a constant, so the levels
// unroll and stay in registers (a run-time J kept 8-lane packs in memory: 12% of an AVX2 batch).
template <std::size_t J, class T>
PGI_LANE_INLINE T estrin(const double* c, const T& u) {
    T q[(J + 1) / 2];
    for (std::size_t j = 0; j < J / 2; ++j) q[j] = lanes::splat<T>(c[2 * j + 1]) * u + c[2 * j];
    if constexpr (J % 2 == 1) q[J / 2] = lanes::splat<T>(c[J - 1]);
    return estrin_levels<(J + 1) / 2>(q, u * u);
}

// sum_{j<J} b[j] (-s)^j and (with_derivative) its derivative in s, sum_{j<J-1} d[j] (-s)^j with d[j - 1] = -j b[j]
// (RealisationEvaluator::rotation keeps them after b).
template <bool with_derivative, std::size_t J, class T>
PGI_LANE_INLINE void bernoulli_sum(const double* b, const double* d, const T& s, T& h, T& dh) {
    const T minus_s = -s;
    h = estrin<J>(b, minus_s);
    if constexpr (with_derivative) dh = estrin<J - 1>(d, minus_s);
}

// h(s) = sum_{j>=1} b_2j (-s)^(j-1) and dh/ds (b = b_2, b_4, ..., b_40, then dh's coefficients): its terms fall like
// (s / 4 pi^2)^j, so for s <= 1/4 ten terms leave tails below 2^-58 of h and of dh (6e-23 and 2e-19 of b_2 and b_4),
// for s <= 1 thirteen (1e-21, 9e-19) and for s <= 4 twenty (8e-21, 2e-18); in closed form beyond. A polynomial of
// fixed degree on each interval, chosen by each lane's own s (each evaluated only when some lane needs it). dh only
// with_derivative (the acceptance test reads h alone).
template <bool with_derivative, class T>
void rotation_coefficient(T s, const std::vector<double>& b, T& h, T& dh) {
    constexpr std::size_t short_terms = 10, middle_terms = 13, long_terms = 20;  // b holds long_terms, then dh's
    const double* d = b.data() + long_terms;
    const auto middle = lanes::both(s > 0.25, s <= 1.0), longer = lanes::both(s > 1.0, s <= 4.0);
    h = dh = T{};
    if (!lanes::all(lanes::either(middle, longer))) bernoulli_sum<with_derivative, short_terms>(b.data(), d, s, h, dh);
    const auto interval = [&](const auto& in, auto terms) {
        if (!lanes::any(in)) return;
        T hi, dhi;
        bernoulli_sum<with_derivative, decltype(terms)::value>(b.data(), d, s, hi, dhi);
        h = lanes::select(in, hi, h);
        if constexpr (with_derivative) dh = lanes::select(in, dhi, dh);
    };
    interval(middle, std::integral_constant<std::size_t, middle_terms>{});
    interval(longer, std::integral_constant<std::size_t, long_terms>{});
    const auto closed = lanes::negate(s <= 4.0);
    if (!lanes::any(closed)) return;
    for (std::size_t w = 0; w < lanes::lanes_of<T>; ++w) {
        if (!lanes::lane(closed, w)) continue;
        double hw, dhw;
        rotation_closed(lanes::lane(s, w), hw, dhw);
        lanes::set_lane(h, w, hw);
        if constexpr (with_derivative) lanes::set_lane(dh, w, dhw);
    }
}

// log_canonical_derivatives' entries into the dense N x N blocks of the Newton step.
template <int N, class T>
struct LanePut {
    LaneRealisation<N, T>& v;
    PGI_LANE_INLINE void operator()(std::size_t, std::size_t j, std::size_t l, const T& ax, const T& ap, const T& dx,
                                    const T& dp) const {
        v.alpha_x[j + N * l] = ax, v.alpha_p[j + N * l] = ap, v.delta_x[j + N * l] = dx, v.delta_p[j + N * l] = dp;
    }
    PGI_LANE_INLINE void diagonal(std::size_t j, const T& e, const T& s) const {
        v.alpha_x[j + N * j] = v.alpha_x[j + N * j] + e;
        v.delta_x[j + N * j] = v.delta_x[j + N * j] + s;
    }
};

template <class T>
struct Vec3 {
    T v[3];
};
template <class T>
PGI_LANE_INLINE Vec3<T> cross(const double* c, const Vec3<T>& a) {  // c x a, c constant
    return {{c[1] * a.v[2] - c[2] * a.v[1], c[2] * a.v[0] - c[0] * a.v[2], c[0] * a.v[1] - c[1] * a.v[0]}};
}
// sign e_j x a (so(3) itself: c_j = sign e_j), the generic cross's values without its products by zero
template <class T>
PGI_LANE_INLINE Vec3<T> axis_cross(int j, double sign, const Vec3<T>& a) {
    const T zero{};
    switch (j) {
        case 0:
            return {{zero, sign * -a.v[2], sign * a.v[1]}};
        case 1:
            return {{sign * a.v[2], zero, sign * -a.v[0]}};
        default:
            return {{sign * -a.v[1], sign * a.v[0], zero}};
    }
}
template <class T>
PGI_LANE_INLINE Vec3<T> cross(const Vec3<T>& b, const Vec3<T>& a) {  // b x a
    return {{b.v[1] * a.v[2] - b.v[2] * a.v[1], b.v[2] * a.v[0] - b.v[0] * a.v[2], b.v[0] * a.v[1] - b.v[1] * a.v[0]}};
}

// L(p)'s axial vector w = sum_j p_j c_j (c_j the axial vector of C_j): sign p where every c_j = sign e_j.
template <class T>
PGI_LANE_INLINE Vec3<T> axial_vector(const double (&c)[3][3], double sign, const T* p) {
    Vec3<T> w;
    for (int i = 0; i < 3; ++i) w.v[i] = sign != 0 ? sign * p[i] : (p[0] * c[0][i] + p[1] * c[1][i]) + p[2] * c[2][i];
    return w;
}

// The so(3) form's common part at (x, p): L(p) v = w x v with w = axial_vector, s = |w|^2 = |L|_F^2 / 2, and L x,
// L^2 x.
template <class T>
struct RotationAt {
    Vec3<T> w, X, Lx, L2x;
    T s;
    [[gnu::always_inline]] RotationAt(const double (&c)[3][3], double sign, const T* x, const T* p) {
        w = axial_vector(c, sign, p);
        s = (w.v[0] * w.v[0] + w.v[1] * w.v[1]) + w.v[2] * w.v[2];
        X = {{x[0], x[1], x[2]}};
        Lx = cross(w, X);
        L2x = cross(w, Lx);
    }
};

}  // namespace

// so(3) on its three coordinates: alpha = x - L x / 2 + h(s) L^2 x (docs/math.md 3), alpha_x = (1 - h s) I - L/2 +
// h w w^T (L^2 = w w^T - s I), alpha_p e_j = -C_j x / 2 + h (c_j x L x + w x C_j x) + dh (2 w . c_j) L^2 x (ds/dp_j =
// 2 w . c_j), delta = L x.
template <class T>
void RealisationEvaluator::rotation_eval(const T* x3, const T* p3, T* alpha, T* delta, T* alpha_x, T* alpha_p,
                                         T* delta_x, T* delta_p) const {
    const RotationAt<T> r(axial_, axial_sign_, x3, p3);
    T h, dh;
    rotation_coefficient<true>(r.s, b_, h, dh);
    const T diagonal = 1.0 - h * r.s;
    for (int i = 0; i < 3; ++i) {
        alpha[i] = (r.X.v[i] - 0.5 * r.Lx.v[i]) + h * r.L2x.v[i];
        delta[i] = r.Lx.v[i];
        for (int k = 0; k < 3; ++k) {
            // L(i, k) = (w x e_k)_i: -w_m on the cycle (0,1), (1,2), (2,0), +w_m off it, m the third index
            const T L_ik = i == k ? T{} : ((i + 1) % 3 == k ? -r.w.v[3 - i - k] : r.w.v[3 - i - k]);
            alpha_x[i + 3 * k] = ((i == k ? diagonal : T{}) - 0.5 * L_ik) + h * (r.w.v[i] * r.w.v[k]);
            delta_x[i + 3 * k] = L_ik;
        }
    }
    const double sign = axial_sign_;
    for (int j = 0; j < 3; ++j) {
        const double* c = axial_[j];
        const Vec3<T> Cx = sign != 0 ? axis_cross(j, sign, r.X) : cross(c, r.X),
                      a = sign != 0 ? axis_cross(j, sign, r.Lx) : cross(c, r.Lx), b = cross(r.w, Cx);
        const T w_c = sign != 0 ? sign * r.w.v[j] : (r.w.v[0] * c[0] + r.w.v[1] * c[1]) + r.w.v[2] * c[2];
        const T slope = dh * (2.0 * w_c);
        for (int i = 0; i < 3; ++i) {
            alpha_p[i + 3 * j] = (-0.5 * Cx.v[i] + h * (a.v[i] + b.v[i])) + slope * r.L2x.v[i];
            delta_p[i + 3 * j] = Cx.v[i];
        }
    }
}

// so(3) on its three coordinates: alpha and delta as rotation_eval, the sizes of alpha's three terms.
template <class T>
void RealisationEvaluator::rotation_check(const T* x3, const T* p3, T* alpha, T* delta, T* size, T* shift) const {
    const RotationAt<T> r(axial_, axial_sign_, x3, p3);
    T h, dh;
    rotation_coefficient<false>(r.s, b_, h, dh);
    for (int i = 0; i < 3; ++i) {
        alpha[i] = (r.X.v[i] - 0.5 * r.Lx.v[i]) + h * r.L2x.v[i];
        shift[i] = h * r.L2x.v[i] - 0.5 * r.Lx.v[i];
        delta[i] = r.Lx.v[i];
        size[i] = (lanes::abs(r.X.v[i]) + 0.5 * lanes::abs(r.Lx.v[i])) + lanes::abs(h) * lanes::abs(r.L2x.v[i]);
    }
}

// so(3) on its three coordinates: delta = L x = w x x (RotationAt's Lx).
template <class T>
void RealisationEvaluator::rotation_delta(const T* x3, const T* p3, T* delta) const {
    const Vec3<T> w = axial_vector(axial_, axial_sign_, p3);
    const Vec3<T> Lx = cross(w, Vec3<T>{{x3[0], x3[1], x3[2]}});
    for (int i = 0; i < 3; ++i) delta[i] = Lx.v[i];
}

namespace {

// x and p at the so(3) form's three coordinates.
template <class T>
PGI_LANE_INLINE void gather_block(const int (&block)[3], const T* x, const T* p, T* x3, T* p3) {
    for (int i = 0; i < 3; ++i) x3[i] = x[block[i]], p3[i] = p[block[i]];
}

}  // namespace

// so(3): rotation_eval on its three coordinates (written in place when they are all of them, N = 3), the others left
// alone (alpha_w = x_w, delta_w = 0, row e_w of alpha_x, no p_w). Log-canonical: poisson/log_canonical.ipp.
// Polynomial: the compiled map's outputs, the derivatives scattered from their patterns.
template <int N, class T>
void RealisationEvaluator::eval_lanes(const T* x, const T* p, LaneRealisation<N, T>& v, LaneMapScratch<T>& s) const {
    if constexpr (N == 3) {
        if (form_ == Form::rotation) {
            rotation_eval(x, p, v.alpha, v.delta, v.alpha_x, v.alpha_p, v.delta_x, v.delta_p);
            return;
        }
    } else if constexpr (N > 3) {
        if (form_ == Form::rotation) {
            T x3[3], p3[3], alpha[3], delta[3], alpha_x[9], alpha_p[9], delta_x[9], delta_p[9];
            gather_block(block_, x, p, x3, p3);
            rotation_eval(x3, p3, alpha, delta, alpha_x, alpha_p, delta_x, delta_p);
            for (int i = 0; i < N; ++i) v.alpha[i] = x[i], v.delta[i] = T{};
            for (auto* m : {v.alpha_x, v.alpha_p, v.delta_x, v.delta_p})
                for (int e = 0; e < N * N; ++e) m[e] = T{};
            for (int i = 0; i < N; ++i) v.alpha_x[i + N * i] = lanes::splat<T>(1.0);
            for (int i = 0; i < 3; ++i) {
                v.alpha[block_[i]] = alpha[i], v.delta[block_[i]] = delta[i];
                for (int k = 0; k < 3; ++k) {
                    const int e = block_[i] + N * block_[k];
                    v.alpha_x[e] = alpha_x[i + 3 * k], v.alpha_p[e] = alpha_p[i + 3 * k];
                    v.delta_x[e] = delta_x[i + 3 * k], v.delta_p[e] = delta_p[i + 3 * k];
                }
            }
            return;
        }
    }
    for (auto* m : {v.alpha_x, v.alpha_p, v.delta_x, v.delta_p})
        for (int e = 0; e < N * N; ++e) m[e] = T{};
    if (form_ == Form::log_canonical) {  // (poisson/log_canonical.ipp)
        log_canonical_derivatives(x, p, v.alpha, v.delta, LanePut<N, T>{v}, v.exponent, v.em1, std::size_t(N));
        return;
    }
    // the compiled polynomial form: alpha, delta, alpha_x, delta_x (pattern_x_), alpha_p, delta_p (pattern_p_), on
    // the leading coordinates' maps when N is fewer than all
    const bool lead = std::size_t(N) < n_;
    const SparsePattern &pattern_x = lead ? leading_.pattern_x : pattern_x_,
                        &pattern_p = lead ? leading_.pattern_p : pattern_p_;
    for (int i = 0; i < N; ++i) s.in[std::size_t(i)] = x[i], s.in[std::size_t(N + i)] = p[i];
    eval_map(lead ? leading_.map : map_, s.in.data(), s.out.data(), s.map);
    const T* o = s.out.data();
    for (int i = 0; i < N; ++i) v.alpha[i] = o[i], v.delta[i] = o[N + i];
    const std::size_t nx = pattern_x.nonzeros(), np = pattern_p.nonzeros();
    const T* ax = o + 2 * N;
    const T* ap = ax + 2 * nx;
    for (std::size_t col = 0; col < std::size_t(N); ++col) {
        for (int k = pattern_x.outer[col]; k < pattern_x.outer[col + 1]; ++k) {
            const std::size_t e = std::size_t(pattern_x.inner[std::size_t(k)]) + N * col;
            v.alpha_x[e] = ax[k], v.delta_x[e] = ax[std::size_t(k) + nx];
        }
        for (int k = pattern_p.outer[col]; k < pattern_p.outer[col + 1]; ++k) {
            const std::size_t e = std::size_t(pattern_p.inner[std::size_t(k)]) + N * col;
            v.alpha_p[e] = ap[k], v.delta_p[e] = ap[std::size_t(k) + np];
        }
    }
}

// so(3): rotation_check on its three coordinates, the others' alpha_w = x_w (size |x_w|, shift and delta 0).
// Polynomial: the compiled values (alpha - x, the neglected parts: their largest |value| in `neglected`), delta
// (with_delta) and the sizes (every coefficient made positive, at (|x|, |p|)) plus |x|. Without with_delta the
// polynomial and log-canonical forms leave c.delta as it was (so(3) writes it: L x is part of alpha).
template <int N, class T>
void RealisationEvaluator::check_lanes(const T* x, const T* p, LaneCheck<N, T>& c, LaneMapScratch<T>& s,
                                       const LaneRealisation<N, T>* near, bool with_delta) const {
    c.neglected = T{};
    if constexpr (N == 3) {
        if (form_ == Form::rotation) {
            rotation_check(x, p, c.alpha, c.delta, c.size, c.shift);
            return;
        }
    } else if constexpr (N > 3) {
        if (form_ == Form::rotation) {
            T x3[3], p3[3], alpha[3], delta[3], size[3], shift[3];
            gather_block(block_, x, p, x3, p3);
            rotation_check(x3, p3, alpha, delta, size, shift);
            for (int i = 0; i < N; ++i) c.alpha[i] = x[i], c.size[i] = lanes::abs(x[i]), c.delta[i] = c.shift[i] = T{};
            for (int i = 0; i < 3; ++i) {
                const int b = block_[i];
                c.alpha[b] = alpha[i], c.delta[b] = delta[i], c.size[b] = size[i], c.shift[b] = shift[i];
            }
            return;
        }
    }
    if (form_ == Form::log_canonical) {
        log_canonical_check(x, p, c.alpha, with_delta ? c.delta : nullptr, c.size, c.shift,
                            near ? near->exponent : nullptr, near ? near->em1 : nullptr, std::size_t(N));
        return;
    }
    const bool lead = std::size_t(N) < n_;
    const CompiledMap& values = lead ? leading_.values : values_map_;
    for (int i = 0; i < N; ++i) s.in[std::size_t(i)] = x[i], s.in[std::size_t(N + i)] = p[i];
    eval_map(values, s.in.data(), s.out.data(), s.map);
    for (int i = 0; i < N; ++i) c.shift[i] = s.out[std::size_t(i)], c.alpha[i] = x[i] + c.shift[i];
    for (std::size_t o = N; o < values.num_outputs(); ++o) c.neglected = lanes::max(c.neglected, lanes::abs(s.out[o]));
    if (with_delta) eval_map(lead ? leading_.delta : delta_map_, s.in.data(), c.delta, s.map);
    for (int i = 0; i < 2 * N; ++i) s.in[std::size_t(i)] = lanes::abs(s.in[std::size_t(i)]);
    eval_map(lead ? leading_.size : size_map_, s.in.data(), c.size, s.map);
    for (int i = 0; i < N; ++i) c.size[i] = c.size[i] + lanes::abs(x[i]);
}

template <int N, class T>
void RealisationEvaluator::delta_lanes(const T* x, const T* p, T* delta, LaneMapScratch<T>& s,
                                       const LaneRealisation<N, T>* near) const {
    if constexpr (N == 3) {
        if (form_ == Form::rotation) {
            rotation_delta(x, p, delta);
            return;
        }
    } else if constexpr (N > 3) {
        if (form_ == Form::rotation) {  // (the other coordinates' delta_w = 0)
            T x3[3], p3[3], d[3];
            gather_block(block_, x, p, x3, p3);
            rotation_delta(x3, p3, d);
            for (int i = 0; i < N; ++i) delta[i] = T{};
            for (int i = 0; i < 3; ++i) delta[block_[i]] = d[i];
            return;
        }
    }
    if (form_ == Form::log_canonical) {
        log_canonical_delta(x, p, delta, near ? near->exponent : nullptr, near ? near->em1 : nullptr, std::size_t(N));
        return;
    }
    for (int i = 0; i < N; ++i) s.in[std::size_t(i)] = x[i], s.in[std::size_t(N + i)] = p[i];
    eval_map(std::size_t(N) < n_ ? leading_.delta : delta_map_, s.in.data(), delta, s.map);
}

#define PGI_REALISATION_LANES(T)                                                                            \
    template void RealisationEvaluator::rotation_eval<T>(const T*, const T*, T*, T*, T*, T*, T*, T*) const; \
    template void RealisationEvaluator::rotation_check<T>(const T*, const T*, T*, T*, T*, T*) const;        \
    template void RealisationEvaluator::rotation_delta<T>(const T*, const T*, T*) const;                    \
    PGI_LANE_FORMS(2, T)                                                                                    \
    PGI_LANE_FORMS(3, T)                                                                                    \
    PGI_LANE_FORMS(4, T)                                                                                    \
    PGI_LANE_FORMS(6, T)
#define PGI_LANE_FORMS(N, T)                                                                                        \
    template void RealisationEvaluator::eval_lanes<N, T>(const T*, const T*, LaneRealisation<N, T>&,                \
                                                         LaneMapScratch<T>&) const;                                 \
    template void RealisationEvaluator::check_lanes<N, T>(const T*, const T*, LaneCheck<N, T>&, LaneMapScratch<T>&, \
                                                          const LaneRealisation<N, T>*, bool) const;                \
    template void RealisationEvaluator::delta_lanes<N, T>(const T*, const T*, T*, LaneMapScratch<T>&,               \
                                                          const LaneRealisation<N, T>*) const;

}  // namespace pgi
