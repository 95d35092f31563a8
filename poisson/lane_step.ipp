// The bodies of LaneStep's members (poisson/lane_step.hpp), over any lane type T: included by lane_step.cpp
// (T = double and Pack, the x86-64 baseline) and by lane_step_avx2.cpp (T = Pack4, compiled for AVX2). Its
// helpers have internal linkage on purpose: each of those files keeps its own copy, compiled for its target.
#pragma once
#include "poisson/detail/newton_internals.hpp"
#include "poisson/lane_step.hpp"
#include "poisson/detail/newton_rules.hpp"
#include "series/compile_lanes.ipp"

#include <cassert>
#include <cmath>
#include <limits>

namespace pgi {

namespace {

// The layouts the kernels read, as this file sees them (baseline_lane_layout, avx2_lane_layout).
[[maybe_unused]] constexpr LaneLayout lane_layout() {
    return {sizeof(NewtonStepper), alignof(NewtonStepper), sizeof(RealisationEvaluator), alignof(RealisationEvaluator),
            sizeof(DtSeriesMap),   alignof(DtSeriesMap),   sizeof(LaneStep<3, double>),  alignof(LaneStep<3, double>)};
}

using lanes::select;

static_assert(lanes::width == CompiledMap::batch_lanes, "a pack's lanes are one block of CompiledMap::eval_batch");

[[maybe_unused]] void eval_dt(const DtSeriesMap& map, const double* in, double dt, double* out, BatchScratch&) {
    map.eval(in, dt, out);
}
// At the planned dt, the lane kernel compiled in this file (for AVX2 in lane_step_avx2.cpp): what map.eval_batch runs
// there (one block of batch_lanes points), the same bits; elsewhere eval_batch itself.
template <std::size_t P>
void eval_dt(const DtSeriesMap& map, const lanes::PackOf<P>* in, double dt, lanes::PackOf<P>* out,
             BatchScratch& scratch) {
    const auto* x = reinterpret_cast<const double*>(in);
    auto* y = reinterpret_cast<double*>(out);
    if (const CompiledMap* planned = map.planned_at(dt))
        eval_tape_lanes<lanes::width>(planned->tape(), x, lanes::width, y, lanes::width, scratch.map.data(),
                                      planned->num_slow_inputs() ? scratch.coefficients.get(*planned, 1) : nullptr);
    else
        map.eval_batch(x, dt, y, lanes::width, scratch);
}
[[maybe_unused]] void predict(const Predictor& p, const double* x, double dt, double* xb, BatchScratch&) {
    p.eval(x, dt, xb);
}
// Predictor::eval_batch's operations: the series, then x added.
template <std::size_t P>
void predict(const Predictor& p, const lanes::PackOf<P>* x, double dt, lanes::PackOf<P>* xb, BatchScratch& scratch) {
    if (p.order() == 0 || !p.series().planned_at(dt)) {
        p.eval_batch(reinterpret_cast<const double*>(x), dt, reinterpret_cast<double*>(xb), lanes::width, scratch);
        return;
    }
    eval_dt(p.series(), x, dt, xb, scratch);
    for (std::size_t i = 0; i < p.series().width(); ++i) xb[i] = xb[i] + x[i];
}

// |v|_inf over v's first m <= N coordinates (m >= 1), a NaN of them propagated.
template <int N, class T>
PGI_LANE_INLINE T inf_norm(const T* v, std::size_t m = N) {
    T r = lanes::abs(v[0]);
    for (int i = 1; i < N; ++i)
        if (std::size_t(i) < m) r = lanes::max_nan(r, lanes::abs(v[i]));
    return r;
}
template <int N, class T>
PGI_LANE_INLINE lanes::mask_t<T> all_finite(const T* v) {
    auto f = lanes::is_finite(v[0]);
    for (int i = 1; i < N; ++i) f = lanes::both(f, lanes::is_finite(v[i]));
    return f;
}
// max_i |r_i| / max(tol_i, min), as std::max folds it (NaN quotients ignored).
template <int N, class T>
PGI_LANE_INLINE T tolerance_ratio(const T* r, const T* tol) {
    T ratio{};
    for (int i = 0; i < N; ++i)
        ratio = lanes::max(ratio,
                           lanes::abs(r[i]) / lanes::max(tol[i], lanes::splat<T>(std::numeric_limits<double>::min())));
    return ratio;
}
template <int N, class T>
PGI_LANE_INLINE void commit(lanes::mask_t<T> m, const T* from, T* to) {
    for (int i = 0; i < N; ++i) to[i] = select(m, from[i], to[i]);
}

// J^{-1} for N <= 4 as the adjugate over the determinant (J column-major; for N = 4 by the 2 x 2 minors of its first
// two rows and of its last two, Laplace's expansion): one division, where the LU's pivots make a chain of N (a
// division's latency is four multiplications'), no row exchanges to select, and a solve is then one product. Without
// pivoting, the correction's error is still about cond(J) u relative, which Newton does not see (the acceptance test
// certifies the step); a singular J gives a non-finite correction, as a zero pivot does.
template <int N, class T>
PGI_LANE_INLINE void small_inverse(const T* J, T* inverse) {
    static_assert(N >= 2 && N <= 4);
    const auto a = [&](int i, int j) -> const T& { return J[i + N * j]; };
    if constexpr (N == 2) {
        const T s = 1.0 / (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0));
        inverse[0] = a(1, 1) * s, inverse[1] = -a(1, 0) * s;
        inverse[2] = -a(0, 1) * s, inverse[3] = a(0, 0) * s;
    } else if constexpr (N == 3) {
        // the cofactors C(i, j); inverse(j, i) = C(i, j) / det
        const T c00 = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1), c01 = a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2),
                c02 = a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0);
        const T s = 1.0 / (a(0, 0) * c00 + a(0, 1) * c01 + a(0, 2) * c02);
        inverse[0 + 3 * 0] = c00 * s, inverse[1 + 3 * 0] = c01 * s, inverse[2 + 3 * 0] = c02 * s;
        inverse[0 + 3 * 1] = (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) * s;
        inverse[1 + 3 * 1] = (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) * s;
        inverse[2 + 3 * 1] = (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) * s;
        inverse[0 + 3 * 2] = (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) * s;
        inverse[1 + 3 * 2] = (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) * s;
        inverse[2 + 3 * 2] = (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) * s;
    } else {
        // the minors of rows 0, 1 (s) and of rows 2, 3 (c) on column pairs (0,1) (0,2) (0,3) (1,2) (1,3) (2,3), c
        // reversed
        const T s0 = a(0, 0) * a(1, 1) - a(1, 0) * a(0, 1), s1 = a(0, 0) * a(1, 2) - a(1, 0) * a(0, 2),
                s2 = a(0, 0) * a(1, 3) - a(1, 0) * a(0, 3), s3 = a(0, 1) * a(1, 2) - a(1, 1) * a(0, 2),
                s4 = a(0, 1) * a(1, 3) - a(1, 1) * a(0, 3), s5 = a(0, 2) * a(1, 3) - a(1, 2) * a(0, 3);
        const T c5 = a(2, 2) * a(3, 3) - a(3, 2) * a(2, 3), c4 = a(2, 1) * a(3, 3) - a(3, 1) * a(2, 3),
                c3 = a(2, 1) * a(3, 2) - a(3, 1) * a(2, 2), c2 = a(2, 0) * a(3, 3) - a(3, 0) * a(2, 3),
                c1 = a(2, 0) * a(3, 2) - a(3, 0) * a(2, 2), c0 = a(2, 0) * a(3, 1) - a(3, 0) * a(2, 1);
        const T s = 1.0 / (((s0 * c5 - s1 * c4) + (s2 * c3 + s3 * c2)) + (s5 * c0 - s4 * c1));
        const auto put = [&](int i, int j, const T& v) { inverse[i + 4 * j] = v * s; };
        put(0, 0, (a(1, 1) * c5 - a(1, 2) * c4) + a(1, 3) * c3);
        put(0, 1, (a(0, 2) * c4 - a(0, 1) * c5) - a(0, 3) * c3);
        put(0, 2, (a(3, 1) * s5 - a(3, 2) * s4) + a(3, 3) * s3);
        put(0, 3, (a(2, 2) * s4 - a(2, 1) * s5) - a(2, 3) * s3);
        put(1, 0, (a(1, 2) * c2 - a(1, 0) * c5) - a(1, 3) * c1);
        put(1, 1, (a(0, 0) * c5 - a(0, 2) * c2) + a(0, 3) * c1);
        put(1, 2, (a(3, 2) * s2 - a(3, 0) * s5) - a(3, 3) * s1);
        put(1, 3, (a(2, 0) * s5 - a(2, 2) * s2) + a(2, 3) * s1);
        put(2, 0, (a(1, 0) * c4 - a(1, 1) * c2) + a(1, 3) * c0);
        put(2, 1, (a(0, 1) * c2 - a(0, 0) * c4) - a(0, 3) * c0);
        put(2, 2, (a(3, 0) * s4 - a(3, 1) * s2) + a(3, 3) * s0);
        put(2, 3, (a(2, 1) * s2 - a(2, 0) * s4) - a(2, 3) * s0);
        put(3, 0, (a(1, 1) * c1 - a(1, 0) * c3) - a(1, 2) * c0);
        put(3, 1, (a(0, 0) * c3 - a(0, 1) * c1) + a(0, 2) * c0);
        put(3, 2, (a(3, 1) * s1 - a(3, 0) * s3) - a(3, 2) * s0);
        put(3, 3, (a(2, 0) * s3 - a(2, 1) * s1) + a(2, 2) * s0);
    }
}

}  // namespace

template <int N, class T>
LaneStep<N, T>::LaneStep(const NewtonStepper& s)
    : gh_(s.with_hessian().width(), T{}), scratch_(s.dim(), T{}), passive_(s.dim() - N, T{}), inputs_(s.dim(), T{}),
      maps_(s.in_->realisation_.lane_scratch<T>()), moving_(s.moving_) {
    assert(moving_ >= 1 && moving_ <= std::size_t(N));  // (the passive coordinates have no bracket)
    if constexpr (lanes != 1) s.size_lane_maps(dt_maps_);
    for (auto& e : H_) e = T{};
    for (auto& e : lu_) e = T{};
    for (auto& e : pivot_inverse_) e = T{};
    for (auto* v : {x_, xb_, good_, p_, r_, dx_})
        for (int i = 0; i < N; ++i) v[i] = T{};
    // (a lane never evaluated, its x not finite, is still read by the masked products of accept_check and polish)
    for (auto* v : {values_.alpha, values_.delta, values_.exponent, values_.em1})
        for (int i = 0; i < N; ++i) v[i] = T{};
    for (auto* v : {values_.alpha_x, values_.alpha_p, values_.delta_x, values_.delta_p})
        for (int e = 0; e < N * N; ++e) v[e] = T{};
    for (auto& m : swaps_) m = lanes::none_mask<T>();
    // Hess S_dt's entries on the first N coordinates: with_hessian's outputs are grad S_dt (every coordinate's),
    // then the Hessian's pattern values
    const SparsePattern& P = s.in_->gradient_.hessian;
    for (std::size_t col = 0; col < std::size_t(N); ++col)
        for (int k = P.outer[col]; k < P.outer[col + 1]; ++k)
            if (const auto row = std::size_t(P.inner[std::size_t(k)]); row < std::size_t(N)) {
                hessian_to_[hessian_count_] = int(row + N * col);
                hessian_from_[hessian_count_++] = int(P.cols + s.in_->gradient_.hessian_value[std::size_t(k)]);
            }
}

template <int N, class T>
PGI_LANE_INLINE T LaneStep<N, T>::state_norm(const T* v) const {
    return moving_ == std::size_t(N) ? inf_norm<N>(v) : inf_norm<N>(v, moving_);
}

// The maps' inputs at point (N values): point itself, or when the stepper has coordinates past N, point then their
// values (magnitudes: their absolute values, for the sizes' map read at |x|).
template <int N, class T>
const T* LaneStep<N, T>::inputs(const T* point, bool magnitudes) {
    if (passive_.empty()) return point;
    for (int i = 0; i < N; ++i) inputs_[std::size_t(i)] = point[i];
    for (std::size_t i = 0; i < passive_.size(); ++i)
        inputs_[N + i] = magnitudes ? lanes::abs(passive_[i]) : passive_[i];
    return inputs_.data();
}

// J's LU with partial pivoting, the row exchanges as masks: for column k, row i > k is exchanged with row k where
// |J(i, k)| > |J(k, k)| (so row k ends with the first largest), then the multipliers and the update. Kept for the
// lanes of F, with the pivots' inverses: a division each, not one per multiplier and per solve (a division's
// latency is four multiplications', and the solve's run one after another; the rounding of a correction differs
// by an ulp, which Newton does not see).
template <int N, class T>
void LaneStep<N, T>::factor(Mask F, const T* J) {
    if constexpr (N <= 4) {
        T inverse[N * N];
        small_inverse<N>(J, inverse);
        commit<N * N>(F, inverse, lu_);
        return;
    }
    T A[N * N], inverse[N];
    for (int e = 0; e < N * N; ++e) A[e] = J[e];
    int swap = 0;
    for (int k = 0; k < N; ++k) {
        for (int i = k + 1; i < N; ++i, ++swap) {
            const Mask exchange = lanes::abs(A[i + N * k]) > lanes::abs(A[k + N * k]);
            for (int j = 0; j < N; ++j) {
                const T a = A[k + N * j], b = A[i + N * j];
                A[k + N * j] = select(exchange, b, a);
                A[i + N * j] = select(exchange, a, b);
            }
            swaps_[swap] = select(F, exchange, swaps_[swap]);
        }
        inverse[k] = 1.0 / A[k + N * k];
        for (int i = k + 1; i < N; ++i) {
            const T l = A[i + N * k] * inverse[k];
            A[i + N * k] = l;
            for (int j = k + 1; j < N; ++j) A[i + N * j] = A[i + N * j] - l * A[k + N * j];
        }
    }
    commit<N * N>(F, A, lu_);
    commit<N>(F, inverse, pivot_inverse_);
}

// d = J^{-1} b with the kept factors: the exchanges, then L (unit diagonal) and U; for N <= 4 the kept inverse's
// product.
template <int N, class T>
void LaneStep<N, T>::solve_kept(const T* b, T* d) const {
    if constexpr (N <= 4) {
        for (int i = 0; i < N; ++i) {
            d[i] = lu_[i] * b[0];
            for (int j = 1; j < N; ++j) d[i] = d[i] + lu_[i + N * j] * b[j];
        }
        return;
    }
    for (int i = 0; i < N; ++i) d[i] = b[i];
    int swap = 0;
    for (int k = 0; k < N; ++k)
        for (int i = k + 1; i < N; ++i, ++swap) {
            const T a = d[k], c = d[i];
            d[k] = select(swaps_[swap], c, a);
            d[i] = select(swaps_[swap], a, c);
        }
    for (int i = 1; i < N; ++i)
        for (int j = 0; j < i; ++j) d[i] = d[i] - lu_[i + N * j] * d[j];
    for (int i = N - 1; i >= 0; --i) {
        for (int j = i + 1; j < N; ++j) d[i] = d[i] - lu_[i + N * j] * d[j];
        d[i] = d[i] * pivot_inverse_[i];
    }
}

// At xb for the lanes of F: p = grad S_dt, H = Hess S_dt (on the first N coordinates), the realisation and its
// derivatives, and J = alpha_x + alpha_p H (written to J for every lane; the rest kept for F's).
template <int N, class T>
void LaneStep<N, T>::evaluate(const NewtonStepper& s, Mask F, T* J) {
    eval_dt(s.with_hessian(), inputs(xb_, false), dt_, gh_.data(), dt_maps_);
    T H[N * N];
    for (auto& e : H) e = T{};
    for (int k = 0; k < hessian_count_; ++k) H[hessian_to_[k]] = gh_[std::size_t(hessian_from_[k])];
    LaneRealisation<N, T> v;
    for (int i = 0; i < N; ++i) v.exponent[i] = v.em1[i] = T{};  // (written by the log-canonical form only)
    s.in_->realisation_.eval_lanes<N>(xb_, gh_.data(), v, maps_);
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) {
            T acc = v.alpha_x[i + N * j];
            for (int k = 0; k < N; ++k) acc = acc + v.alpha_p[i + N * k] * H[k + N * j];
            J[i + N * j] = acc;
        }
    commit<N>(F, gh_.data(), p_);
    commit<N * N>(F, H, H_);
    commit<N>(F, v.alpha, values_.alpha);
    commit<N>(F, v.delta, values_.delta);
    commit<N * N>(F, v.alpha_x, values_.alpha_x);
    commit<N * N>(F, v.alpha_p, values_.alpha_p);
    commit<N * N>(F, v.delta_x, values_.delta_x);
    commit<N * N>(F, v.delta_p, values_.delta_p);
    commit<N>(F, v.exponent, values_.exponent);
    commit<N>(F, v.em1, values_.em1);
}

// NewtonStepper::accept_check for the lanes of C: p updated by the Hessian where small (else grad S_dt anew), the
// realisation's values there, r = alpha - x against kappa u (|x| + sizes), the round-off of grad S_dt's terms
// carried by alpha_p added where the stricter test fails. The lanes of C that pass.
template <int N, class T>
typename LaneStep<N, T>::Mask LaneStep<N, T>::accept_check(const NewtonStepper& s, Mask C, Mask small) {
    const Mask by_hessian = lanes::both(C, small), anew = lanes::both(C, lanes::negate(small));
    if (lanes::any(by_hessian)) {
        T p[N];
        for (int i = 0; i < N; ++i) {
            T q{};
            for (int k = 0; k < N; ++k) q = q + H_[i + N * k] * dx_[k];
            p[i] = p_[i] - q;
        }
        commit<N>(by_hessian, p, p_);
    }
    if (lanes::any(anew)) {
        eval_dt(s.in_->gradient_.gradient, inputs(xb_, false), dt_, scratch_.data(), dt_maps_);
        commit<N>(anew, scratch_.data(), p_);
    }
    // (values_: this step's last Newton system, nearby; delta is taken once, by finish)
    s.in_->realisation_.check_lanes<N>(xb_, p_, check_, maps_, &values_, /*with_delta=*/false);
    T r[N], tol[N];
    for (int i = 0; i < N; ++i) {
        r[i] = (xb_[i] - x_[i]) + check_.shift[i];  // alpha - x to below the ulps of x
        tol[i] = (residual_kappa * unit_roundoff) * (lanes::abs(x_[i]) + check_.size[i]);
    }
    T ratio = tolerance_ratio<N>(r, tol);
    const Mask strict_fails = lanes::both(C, lanes::negate(ratio <= 1.0));
    if (lanes::any(strict_fails)) {
        T absolute[N], wide[N];
        for (int i = 0; i < N; ++i) absolute[i] = lanes::abs(xb_[i]);
        eval_dt(s.in_->gradient_.gradient_size, inputs(absolute, true), std::abs(dt_), scratch_.data(), dt_maps_);
        const T* sizes = scratch_.data();
        constexpr double c = residual_kappa * unit_roundoff;
        for (int i = 0; i < N; ++i) {
            wide[i] = tol[i];
            for (int l = 0; l < N; ++l) wide[i] = wide[i] + c * lanes::abs(values_.alpha_p[i + N * l]) * sizes[l];
        }
        ratio = select(strict_fails, tolerance_ratio<N>(r, wide), ratio);
        commit<N>(strict_fails, wide, tol);
    }
    commit<N>(C, r, r_);
    residual_ = select(C, inf_norm<N>(r), residual_);
    ratio_ = select(C, ratio, ratio_);
    tolerance_ = select(C, state_norm(tol), tolerance_);
    const T size =
        lanes::max(lanes::max(x_norm_, state_norm(xb_)), lanes::splat<T>(std::numeric_limits<double>::min()));
    truncation_ = select(C, check_.neglected / size, truncation_);
    return lanes::both(C, ratio <= 1.0);
}

// NewtonStepper::polish for the lanes of E: the increment moved to first order by one more simplified round from the
// accepted r_ (d = J^{-1} r_ with the kept factors, p moved by the kept Hessian): by -(delta_x d + delta_p H d),
// delta's derivatives from the last Newton system.
template <int N, class T>
void LaneStep<N, T>::polish(Mask E, T* delta) const {
    T d[N], q[N];
    solve_kept(r_, d);
    const Mask go = lanes::both(E, all_finite<N>(d));
    for (int i = 0; i < N; ++i) {
        q[i] = T{};
        for (int k = 0; k < N; ++k) q[i] = q[i] + H_[i + N * k] * d[k];
    }
    for (int i = 0; i < N; ++i) {
        T moved{};
        for (int k = 0; k < N; ++k) moved = moved + values_.delta_x[i + N * k] * d[k];
        for (int k = 0; k < N; ++k) moved = moved + values_.delta_p[i + N * k] * q[k];
        delta[i] = select(go, delta[i] - moved, delta[i]);
    }
}

// NewtonStepper::finish for the lanes of E (accepted): ill-conditioned when the tolerance exceeds sqrt(u) |x|, else
// the increment delta at the accepted base point, evaluated here once for every lane and polished, non-finite, above
// the truncation bound, or ok.
template <int N, class T>
void LaneStep<N, T>::finish(const NewtonStepper& s, Mask E, T* increment) {
    const Mask ill =
        lanes::both(E, newton_rules::ill_conditioned(tolerance_, newton_rules::noise(x_norm_, state_norm(xb_))));
    end(ill, StepStatus::ill_conditioned);
    const Mask solved = lanes::both(E, lanes::negate(ill));
    if (!lanes::any(solved)) return;  // (a failed test: no delta to take)
    s.in_->realisation_.delta_lanes<N>(xb_, p_, check_.delta, maps_, &values_);
    polish(solved, check_.delta);
    commit<N>(solved, check_.delta, increment);
    const Mask non_finite = lanes::both(solved, lanes::negate(all_finite<N>(check_.delta)));
    end(non_finite, StepStatus::non_finite);
    const Mask finite = lanes::both(solved, lanes::negate(non_finite)), above = truncation_ > s.opt_.truncation_bound;
    end(lanes::both(finite, above), StepStatus::truncation_above_bound);
    end(lanes::both(finite, lanes::negate(above)), StepStatus::ok);
}

// The lanes of E leave Newton in this round with st (close_round decides: a second attempt, or the end); the
// status is kept as a number in each lane, so this is a few vector operations.
template <int N, class T>
void LaneStep<N, T>::end(Mask E, StepStatus st) {
    E = lanes::both(E, lanes::negate(ended_));
    ended_code_ = select(E, lanes::splat<T>(double(static_cast<int>(st))), ended_code_);
    ended_ = lanes::either(ended_, E);
}

// NewtonStepper::newton's state at its start, for the lanes of R (their iteration 1).
template <int N, class T>
void LaneStep<N, T>::restart(Mask R) {
    const T inf = lanes::splat<T>(std::numeric_limits<double>::infinity()), one = lanes::splat<T>(1.0);
    previous_ = select(R, inf, previous_);
    previous_residual_ = select(R, inf, previous_residual_);
    good_residual_ = select(R, inf, good_residual_);
    lambda_ = select(R, one, lambda_);
    it_ = select(R, one, it_);
    simplified_ = select(R, lanes::none_mask<T>(), simplified_);
    running_ = lanes::either(running_, R);
}

// One iteration of NewtonStepper::newton's loop on every running lane: simplified (the acceptance test, then the
// kept factors) or full (the Newton system, backtracking, the solve, and the test once settled).
template <int N, class T>
void LaneStep<N, T>::round(const NewtonStepper& s, T* increment) {
    const Mask S = lanes::both(running_, simplified_), F = lanes::both(running_, lanes::negate(simplified_));
    if (lanes::any(S)) {
        const Mask accepted = accept_check(s, S, lanes::none_mask<T>());
        finish(s, accepted, increment);
        const Mask rest = lanes::both(S, lanes::negate(accepted));
        end(lanes::both(rest, lanes::negate(lanes::is_finite(residual_))), StepStatus::non_finite);
        const Mask go = lanes::both(rest, lanes::is_finite(residual_));
        if (lanes::any(go)) {
            T d[N];
            solve_kept(r_, d);
            commit<N>(go, d, dx_);
            for (int i = 0; i < N; ++i) xb_[i] = select(go, xb_[i] - d[i], xb_[i]);
            iterations_ = select(go, it_, iterations_);
            const T c = inf_norm<N>(d);
            end(lanes::both(go, lanes::negate(lanes::is_finite(c))), StepStatus::non_finite);
            const Mask on = lanes::both(go, lanes::is_finite(c));
            simplified_ = select(on, newton_rules::stays_simplified(c, correction_), simplified_);
            correction_ = select(on, c, correction_);
            previous_ = select(on, c, previous_);
            previous_residual_ = select(on, residual_, previous_residual_);
        }
    }
    if (!lanes::any(F)) return;
    T J[N * N], r[N];
    evaluate(s, F, J);
    for (int i = 0; i < N; ++i) r[i] = values_.alpha[i] - x_[i];
    const T residual = inf_norm<N>(r);
    commit<N>(F, r, r_);
    residual_ = select(F, residual, residual_);
    // backtracking along the last correction while the residual grows above the noise (newton_rules)
    const T noise = newton_rules::noise(x_norm_, state_norm(xb_));
    const Mask back = lanes::both(F, newton_rules::backtracks(residual, good_residual_, noise, lambda_));
    lambda_ = select(back, lambda_ / 2, lambda_);
    for (int i = 0; i < N; ++i) xb_[i] = select(back, good_[i] - lambda_ * dx_[i], xb_[i]);
    const Mask forward = lanes::both(F, lanes::negate(back));
    const Mask bad = lanes::both(
        forward, lanes::either(lanes::negate(lanes::is_finite(residual)), lanes::negate(all_finite<N>(values_.delta))));
    end(bad, StepStatus::non_finite);
    const Mask go = lanes::both(forward, lanes::negate(bad));
    if (!lanes::any(go)) return;
    good_residual_ = select(go, residual, good_residual_);
    lambda_ = select(go, lanes::splat<T>(1.0), lambda_);
    commit<N>(go, xb_, good_);
    factor(go, J);
    T d[N];
    solve_kept(r, d);
    commit<N>(go, d, dx_);
    for (int i = 0; i < N; ++i) xb_[i] = select(go, xb_[i] - d[i], xb_[i]);
    iterations_ = select(go, it_, iterations_);
    const T c = inf_norm<N>(d);
    correction_ = select(go, c, correction_);
    end(lanes::both(go, lanes::negate(lanes::is_finite(c))), StepStatus::non_finite);
    const Mask on = lanes::both(go, lanes::is_finite(c));
    const T scale = lanes::max(x_norm_, state_norm(xb_));
    const Mask small = newton_rules::small(c, s.opt_.newton_tol, scale);
    const Mask settled = newton_rules::settled(small, c, previous_, residual, previous_residual_);
    previous_ = select(on, c, previous_);
    previous_residual_ = select(on, residual, previous_residual_);
    const Mask test = lanes::both(on, settled);
    Mask accepted = lanes::none_mask<T>();
    if (lanes::any(test)) {
        accepted = accept_check(s, test, small);
        finish(s, accepted, increment);
    }
    const Mask next = lanes::both(on, lanes::negate(accepted));
    const Mask simplify = newton_rules::simplifies(s.in_->simplified_newton_, small, c, scale);
    simplified_ = select(next, simplify, simplified_);
}

// After a round: the running lanes that did not end go to their next iteration (ending unconverged past the
// limit); the ended ones either start their second attempt from xb = x (NewtonStepper::solve_from_prediction:
// a first attempt that failed, with a predictor) or stop with their status.
template <int N, class T>
void LaneStep<N, T>::close_round(const NewtonStepper& s, StepStatus* status) {
    const Mask going = lanes::both(running_, lanes::negate(ended_));
    it_ = select(going, it_ + 1.0, it_);
    end(lanes::both(going, it_ > double(s.opt_.newton_max_iter)), StepStatus::newton_not_converged);
    if (!lanes::any(ended_)) return;
    const Mask solved = lanes::either(ended_code_ == double(static_cast<int>(StepStatus::ok)),
                                      ended_code_ == double(static_cast<int>(StepStatus::truncation_above_bound)));
    const Mask retry = s.info_.predictor_order == 0
                           ? lanes::none_mask<T>()
                           : lanes::both(lanes::both(ended_, lanes::negate(solved)), lanes::negate(second_));
    const Mask final = lanes::both(ended_, lanes::negate(retry));
    iterations_ = select(lanes::both(final, second_), iterations_ + spent_, iterations_);
    running_ = lanes::both(running_, lanes::negate(final));
    if (lanes::any(retry)) {
        spent_ = select(retry, iterations_, spent_);
        commit<N>(retry, x_, xb_);
        second_ = lanes::either(second_, retry);
        restart(retry);
    }
    for (std::size_t w = 0; w < lanes; ++w)
        if (lanes::lane(final, w)) status[w] = static_cast<StepStatus>(static_cast<int>(lanes::lane(ended_code_, w)));
    ended_ = lanes::none_mask<T>();
}

template <int N, class T>
void LaneStep<N, T>::step(const NewtonStepper& s, const T* x, double dt, T* increment, StepStatus* status) {
    iterations_ = residual_ = tolerance_ = ratio_ = truncation_ = T{};
    second_ = ended_ = running_ = lanes::none_mask<T>();
    for (std::size_t w = 0; w < lanes; ++w) status[w] = StepStatus::non_finite;
    if (!std::isfinite(dt)) return;
    dt_ = dt;
    for (int i = 0; i < N; ++i) x_[i] = x[i];
    Mask finite = all_finite<N>(x_);
    x_norm_ = state_norm(x_);
    for (const T& w : passive_) finite = lanes::both(finite, lanes::is_finite(w));
    if (!lanes::any(finite)) return;
    if (passive_.empty()) {
        predict(s.predictor(), x_, dt, xb_, dt_maps_);
    } else {  // the predictor's series is every coordinate's (the passive ones' zero)
        predict(s.predictor(), inputs(x_, false), dt, scratch_.data(), dt_maps_);
        for (int i = 0; i < N; ++i) xb_[i] = scratch_[std::size_t(i)];
    }
    restart(finite);
    while (lanes::any(running_)) {
        round(s, increment);
        close_round(s, status);
    }
}

}  // namespace pgi
