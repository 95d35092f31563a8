#pragma once
// Lanes: the arithmetic of the step written once for one state (T = double) and for lanes::width states at
// once (T = lanes::Pack: each operation acts lane by lane, as SIMD instructions). The step's kernels (poisson/lane_step, the realisation's lane forms) are templates
// over T, so every lane of a Pack goes through the operations of the double instantiation in the same order:
// its bits are the single step's (IEEE operations are exactly rounded; the library is built with
// -ffp-contract=off, so no multiply-add is fused in one instantiation and not the other). Control that
// depends on a lane's values is a mask (M = mask_t<T>: bool, or a vector of all-ones / zero lanes) and a
// select, never a branch, except where every lane agrees (any / all).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

// GCC notes that a 64-byte vector returned by value passes differently with and without AVX-512: these
// functions are inline, and no Pack crosses pgi's compiled interface by value.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace pgi::lanes {

// The kernels' arithmetic is inlined whatever GCC's size heuristics say: a call per Pack operation costs more
// than the operation.
#define PGI_LANE_INLINE [[gnu::always_inline]] inline

inline constexpr std::size_t width = 8;

// A Pack is width / 2 native two-lane vectors (SSE2, the x86-64 baseline): GCC lowers comparisons and selects of
// wider vector types than the target has lane by lane, with branches; on its own width every operation is one
// instruction. Lane w is part w / 2, element w % 2; the doubles lie in lane order (a Pack array is a structure
// of arrays: element v of lane w at v width + w).
using Pair = double __attribute__((vector_size(16)));
using PairMask = std::int64_t __attribute__((vector_size(16)));
inline constexpr std::size_t parts = width / 2;

struct PackMask {
    PairMask p[parts];
};
struct Pack {
    Pair p[parts];
};

#define PGI_LANES_BINARY(OP)                                                                        \
    PGI_LANE_INLINE Pack operator OP(const Pack& a, const Pack& b) {                                         \
        Pack r;                                                                                     \
        for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] OP b.p[k];                          \
        return r;                                                                                   \
    }                                                                                               \
    PGI_LANE_INLINE Pack operator OP(const Pack& a, double b) {                                              \
        Pack r;                                                                                     \
        for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] OP b;                               \
        return r;                                                                                   \
    }                                                                                               \
    PGI_LANE_INLINE Pack operator OP(double a, const Pack& b) {                                              \
        Pack r;                                                                                     \
        for (std::size_t k = 0; k < parts; ++k) r.p[k] = a OP b.p[k];                               \
        return r;                                                                                   \
    }                                                                                               \
    PGI_LANE_INLINE Pack& operator OP##=(Pack& a, const Pack& b) { return a = a OP b; }
PGI_LANES_BINARY(+)
PGI_LANES_BINARY(-)
PGI_LANES_BINARY(*)
PGI_LANES_BINARY(/)
#undef PGI_LANES_BINARY
PGI_LANE_INLINE Pack operator-(const Pack& a) {
    Pack r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = -a.p[k];
    return r;
}
#define PGI_LANES_COMPARE(OP)                                                                       \
    PGI_LANE_INLINE PackMask operator OP(const Pack& a, const Pack& b) {                                     \
        PackMask r;                                                                                 \
        for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] OP b.p[k];                          \
        return r;                                                                                   \
    }                                                                                               \
    PGI_LANE_INLINE PackMask operator OP(const Pack& a, double b) {                                          \
        PackMask r;                                                                                 \
        for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] OP b;                               \
        return r;                                                                                   \
    }
PGI_LANES_COMPARE(<)
PGI_LANES_COMPARE(<=)
PGI_LANES_COMPARE(>)
PGI_LANES_COMPARE(==)
PGI_LANES_COMPARE(!=)
#undef PGI_LANES_COMPARE

template <class T>
struct traits;
template <>
struct traits<double> {
    using mask = bool;
    static constexpr std::size_t lanes = 1;
};
template <>
struct traits<Pack> {
    using mask = PackMask;
    static constexpr std::size_t lanes = width;
};
template <class T>
using mask_t = typename traits<T>::mask;
template <class T>
inline constexpr std::size_t lanes_of = traits<T>::lanes;

// Every lane c.
template <class T>
PGI_LANE_INLINE T splat(double c) {
    if constexpr (std::is_same_v<T, double>)
        return c;
    else
    {
        T r;
        for (auto& part : r.p) part = Pair{c, c};
        return r;
    }
}

PGI_LANE_INLINE double select(bool m, double a, double b) { return m ? a : b; }
PGI_LANE_INLINE bool select(bool m, bool a, bool b) { return m ? a : b; }
PGI_LANE_INLINE Pack select(const PackMask& m, const Pack& a, const Pack& b) {
    Pack r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = (Pair)(((PairMask)a.p[k] & m.p[k]) | ((PairMask)b.p[k] & ~m.p[k]));
    return r;
}
PGI_LANE_INLINE PackMask select(const PackMask& m, const PackMask& a, const PackMask& b) {
    PackMask r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = (a.p[k] & m.p[k]) | (b.p[k] & ~m.p[k]);
    return r;
}

PGI_LANE_INLINE bool both(bool a, bool b) { return a && b; }
PGI_LANE_INLINE bool either(bool a, bool b) { return a || b; }
PGI_LANE_INLINE bool negate(bool a) { return !a; }
PGI_LANE_INLINE PackMask both(const PackMask& a, const PackMask& b) {
    PackMask r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] & b.p[k];
    return r;
}
PGI_LANE_INLINE PackMask either(const PackMask& a, const PackMask& b) {
    PackMask r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = a.p[k] | b.p[k];
    return r;
}
PGI_LANE_INLINE PackMask negate(const PackMask& a) {
    PackMask r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = ~a.p[k];
    return r;
}
PGI_LANE_INLINE bool any(bool m) { return m; }
PGI_LANE_INLINE bool all(bool m) { return m; }
PGI_LANE_INLINE bool any(const PackMask& m) {
    PairMask o = m.p[0];
    for (std::size_t k = 1; k < parts; ++k) o |= m.p[k];
    return (o[0] | o[1]) != 0;
}
PGI_LANE_INLINE bool all(const PackMask& m) { return !any(negate(m)); }
template <class T>
PGI_LANE_INLINE mask_t<T> none_mask() {
    if constexpr (std::is_same_v<T, double>)
        return false;
    else
        return PackMask{};
}
template <class T>
PGI_LANE_INLINE mask_t<T> all_mask() { return negate(none_mask<T>()); }

// |a|: the sign bit cleared (std::fabs's bits, -0 included).
PGI_LANE_INLINE double abs(double a) { return std::fabs(a); }
PGI_LANE_INLINE Pack abs(const Pack& a) {
    Pack r;
    for (std::size_t k = 0; k < parts; ++k) r.p[k] = (Pair)((PairMask)a.p[k] & INT64_MAX);
    return r;
}

// std::max(a, b)'s rule lane by lane: b if a < b, else a (so a NaN in b is ignored).
template <class T>
PGI_LANE_INLINE T max(T a, T b) { return select(a < b, b, a); }
// The larger, or a NaN of either: for norms whose finiteness is tested.
template <class T>
PGI_LANE_INLINE T max_nan(T a, T b) { return select(either(a < b, b != b), b, a); }
// Finite (neither infinite nor NaN): a - a is 0 exactly then.
template <class T>
PGI_LANE_INLINE mask_t<T> is_finite(T a) { return a - a == T{}; }

PGI_LANE_INLINE double lane(double a, std::size_t) { return a; }
PGI_LANE_INLINE double lane(const Pack& a, std::size_t w) { return a.p[w / 2][w % 2]; }
PGI_LANE_INLINE bool lane(bool m, std::size_t) { return m; }
PGI_LANE_INLINE bool lane(const PackMask& m, std::size_t w) { return m.p[w / 2][w % 2] != 0; }
PGI_LANE_INLINE void set_lane(double& a, std::size_t, double v) { a = v; }
PGI_LANE_INLINE void set_lane(Pack& a, std::size_t w, double v) { a.p[w / 2][w % 2] = v; }
PGI_LANE_INLINE void set_lane(bool& m, std::size_t, bool v) { m = v; }
PGI_LANE_INLINE void set_lane(PackMask& m, std::size_t w, bool v) { m.p[w / 2][w % 2] = v ? -1 : 0; }

}  // namespace pgi::lanes
