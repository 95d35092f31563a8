#pragma once
// Lanes: the arithmetic of the step written once for one state (T = double) and for lanes::width states at
// once (T = a Pack: each operation acts lane by lane, as SIMD instructions). The step's kernels
// (poisson/lane_step, the realisation's lane forms) are templates over T, so every lane of a Pack goes through
// the operations of the double instantiation in the same order: its bits are the single step's (IEEE
// operations are exactly rounded; the library is built with -ffp-contract=off, so no multiply-add is fused in
// one instantiation and not the other). Control that depends on a lane's values is a mask (mask_t<T>: bool, or
// all-ones / zero lanes) and a select, never a branch, except where every lane agrees (any / all).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

// GCC notes that vectors returned by value pass differently with and without AVX: these functions are inline,
// and no Pack crosses pgi's compiled interface by value.
#pragma GCC diagnostic ignored "-Wpsabi"

// pgi.hpp never includes this header (tests/public_header.cpp checks it): the macro says it was included.
#define PGI_LANE_KERNELS_INCLUDED 1

namespace pgi::lanes {

// The kernels' arithmetic is inlined whatever GCC's size heuristics say: a call per Pack operation costs more
// than the operation.
#define PGI_LANE_INLINE [[gnu::always_inline]] inline

inline constexpr std::size_t width = 8;

// A pack of width lanes is width / P native vectors of P doubles: P = 2 for SSE2, the x86-64 baseline (Pack),
// P = 4 for AVX2 (Pack4, compiled only in poisson/lane_step_avx2.cpp, run only where the processor has AVX2).
// GCC lowers comparisons and selects on vectors wider than the target has lane by lane, with branches; on its
// own width every operation is one instruction. Lane w is part w / P, element w % P; the doubles lie in lane
// order either way (an array of packs is a structure of arrays: element v of lane w at v width + w).
template <std::size_t P>
struct Part;
template <>
struct Part<2> {
    using value = double __attribute__((vector_size(16)));
    using mask = std::int64_t __attribute__((vector_size(16)));
};
template <>
struct Part<4> {
    // aligned explicitly: a file compiled for the baseline gives a 32-byte vector only 16-byte alignment (its
    // largest), one compiled for AVX2 32, and Pack4's layout must be the same in both
    using value = double __attribute__((vector_size(32), aligned(32)));
    using mask = std::int64_t __attribute__((vector_size(32), aligned(32)));
};

template <std::size_t P>
struct alignas(8 * P) MaskOf {
    static constexpr std::size_t parts = width / P;
    typename Part<P>::mask p[parts];
};
template <std::size_t P>
struct alignas(8 * P) PackOf {
    static constexpr std::size_t parts = width / P;
    typename Part<P>::value p[parts];
};
using Pack = PackOf<2>;
using Pack4 = PackOf<4>;

// R's parts from f(k), part by part: every operation of a pack below.
template <class R, class F>
PGI_LANE_INLINE R by_parts(F&& f) {
    R r;
    for (std::size_t k = 0; k < R::parts; ++k) r.p[k] = f(k);
    return r;
}

// a OP b with a pack on either side (or both), a Pack's or a mask's result: one line per operator.
#define PGI_LANES_OPERATOR(R, OP)                                            \
    template <std::size_t P>                                                 \
    PGI_LANE_INLINE R operator OP(const PackOf<P>& a, const PackOf<P>& b) {  \
        return by_parts<R>([&](std::size_t k) { return a.p[k] OP b.p[k]; }); \
    }                                                                        \
    template <std::size_t P>                                                 \
    PGI_LANE_INLINE R operator OP(const PackOf<P>& a, double b) {            \
        return by_parts<R>([&](std::size_t k) { return a.p[k] OP b; });      \
    }                                                                        \
    template <std::size_t P>                                                 \
    PGI_LANE_INLINE R operator OP(double a, const PackOf<P>& b) {            \
        return by_parts<R>([&](std::size_t k) { return a OP b.p[k]; });      \
    }
PGI_LANES_OPERATOR(PackOf<P>, +)
PGI_LANES_OPERATOR(PackOf<P>, -)
PGI_LANES_OPERATOR(PackOf<P>, *)
PGI_LANES_OPERATOR(PackOf<P>, /)
PGI_LANES_OPERATOR(MaskOf<P>, <)
PGI_LANES_OPERATOR(MaskOf<P>, <=)
PGI_LANES_OPERATOR(MaskOf<P>, >)
PGI_LANES_OPERATOR(MaskOf<P>, ==)
PGI_LANES_OPERATOR(MaskOf<P>, !=)
#undef PGI_LANES_OPERATOR
template <std::size_t P>
PGI_LANE_INLINE PackOf<P>& operator*=(PackOf<P>& a, const PackOf<P>& b) {
    return a = a * b;
}
template <std::size_t P>
PGI_LANE_INLINE PackOf<P> operator-(const PackOf<P>& a) {
    return by_parts<PackOf<P>>([&](std::size_t k) { return -a.p[k]; });
}

template <class T>
struct traits;
template <std::size_t P>
struct traits<PackOf<P>> {
    using mask = MaskOf<P>;
    static constexpr std::size_t lanes = width;
};
template <>
struct traits<double> {
    using mask = bool;
    static constexpr std::size_t lanes = 1;
};
template <class T>
using mask_t = typename traits<T>::mask;
template <class T>
inline constexpr std::size_t lanes_of = traits<T>::lanes;

// Every lane c.
template <class T>
PGI_LANE_INLINE T splat(double c) {
    if constexpr (std::is_same_v<T, double>) {
        return c;
    } else {
        T r;
        for (auto& part : r.p) {
            for (std::size_t e = 0; e < width / r.parts; ++e) part[e] = c;
        }
        return r;
    }
}

PGI_LANE_INLINE double select(bool m, double a, double b) {
    return m ? a : b;
}
PGI_LANE_INLINE bool select(bool m, bool a, bool b) {
    return m ? a : b;
}
template <std::size_t P>
PGI_LANE_INLINE PackOf<P> select(const MaskOf<P>& m, const PackOf<P>& a, const PackOf<P>& b) {
    using M = typename Part<P>::mask;
    using V = typename Part<P>::value;
    return by_parts<PackOf<P>>([&](std::size_t k) { return (V)(((M)a.p[k] & m.p[k]) | ((M)b.p[k] & ~m.p[k])); });
}
template <std::size_t P>
PGI_LANE_INLINE MaskOf<P> select(const MaskOf<P>& m, const MaskOf<P>& a, const MaskOf<P>& b) {
    return by_parts<MaskOf<P>>([&](std::size_t k) { return (a.p[k] & m.p[k]) | (b.p[k] & ~m.p[k]); });
}

PGI_LANE_INLINE bool both(bool a, bool b) {
    return a && b;
}
PGI_LANE_INLINE bool either(bool a, bool b) {
    return a || b;
}
PGI_LANE_INLINE bool negate(bool a) {
    return !a;
}
template <std::size_t P>
PGI_LANE_INLINE MaskOf<P> both(const MaskOf<P>& a, const MaskOf<P>& b) {
    return by_parts<MaskOf<P>>([&](std::size_t k) { return a.p[k] & b.p[k]; });
}
template <std::size_t P>
PGI_LANE_INLINE MaskOf<P> either(const MaskOf<P>& a, const MaskOf<P>& b) {
    return by_parts<MaskOf<P>>([&](std::size_t k) { return a.p[k] | b.p[k]; });
}
template <std::size_t P>
PGI_LANE_INLINE MaskOf<P> negate(const MaskOf<P>& a) {
    return by_parts<MaskOf<P>>([&](std::size_t k) { return ~a.p[k]; });
}
PGI_LANE_INLINE bool any(bool m) {
    return m;
}
PGI_LANE_INLINE bool all(bool m) {
    return m;
}
template <std::size_t P>
PGI_LANE_INLINE bool any(const MaskOf<P>& m) {
    typename Part<P>::mask o = m.p[0];
    for (std::size_t k = 1; k < m.parts; ++k) o |= m.p[k];
    std::int64_t e = 0;
    for (std::size_t i = 0; i < P; ++i) e |= o[i];
    return e != 0;
}
template <std::size_t P>
PGI_LANE_INLINE bool all(const MaskOf<P>& m) {
    return !any(negate(m));
}
template <class T>
PGI_LANE_INLINE mask_t<T> none_mask() {
    if constexpr (std::is_same_v<T, double>)
        return false;
    else
        return mask_t<T>{};
}
template <class T>
PGI_LANE_INLINE mask_t<T> all_mask() {
    return negate(none_mask<T>());
}

// |a|: the sign bit cleared (std::fabs's bits, -0 included).
PGI_LANE_INLINE double abs(double a) {
    return std::fabs(a);
}
template <std::size_t P>
PGI_LANE_INLINE PackOf<P> abs(const PackOf<P>& a) {
    using M = typename Part<P>::mask;
    using V = typename Part<P>::value;
    return by_parts<PackOf<P>>([&](std::size_t k) { return (V)((M)a.p[k] & INT64_MAX); });
}

// std::max(a, b)'s rule lane by lane: b if a < b, else a (so a NaN in b is ignored).
template <class T>
PGI_LANE_INLINE T max(T a, T b) {
    return select(a < b, b, a);
}
// The larger, or a NaN of either: for norms whose finiteness is tested.
template <class T>
PGI_LANE_INLINE T max_nan(T a, T b) {
    return select(either(a < b, b != b), b, a);
}
// Finite (neither infinite nor NaN): a - a is 0 exactly then.
template <class T>
PGI_LANE_INLINE mask_t<T> is_finite(T a) {
    return a - a == T{};
}

PGI_LANE_INLINE double lane(double a, std::size_t) {
    return a;
}
PGI_LANE_INLINE bool lane(bool m, std::size_t) {
    return m;
}
PGI_LANE_INLINE void set_lane(double& a, std::size_t, double v) {
    a = v;
}
PGI_LANE_INLINE void set_lane(bool& m, std::size_t, bool v) {
    m = v;
}
template <std::size_t P>
PGI_LANE_INLINE double lane(const PackOf<P>& a, std::size_t w) {
    return a.p[w / P][w % P];
}
template <std::size_t P>
PGI_LANE_INLINE bool lane(const MaskOf<P>& m, std::size_t w) {
    return m.p[w / P][w % P] != 0;
}
template <std::size_t P>
PGI_LANE_INLINE void set_lane(PackOf<P>& a, std::size_t w, double v) {
    a.p[w / P][w % P] = v;
}
template <std::size_t P>
PGI_LANE_INLINE void set_lane(MaskOf<P>& m, std::size_t w, bool v) {
    m.p[w / P][w % P] = v ? -1 : 0;
}

}  // namespace pgi::lanes
