// CompiledMap::eval_with's groups of four outputs, written once over the type of their four partial sums: two
// pairs of SSE2 lanes and long double lanes (series/compile.cpp), one AVX2 vector (series/compile_avx2.cpp). A
// group's terms go round-robin into four partial sums (one running sum would wait on the adder at every term),
// paired as (s0 + s1) + (s2 + s3), as a row's. Internal linkage on purpose: each including file keeps its own copy,
// compiled for its target.
#pragma once
#include "series/compile.hpp"

namespace pgi {

namespace {

// Group g's four lanes, each the sum ((s0 + s1) + (s2 + s3)) of its partial sums. Sums: four lanes, value-initialised
// to +0; add<true>(c, m) adds c[i] m to lane i where c[i] is not zero (a padding zero adds nothing, even times an
// infinite or NaN monomial), add<false> adds every c[i] m; [i] reads lane i.
template <bool masked, class Sums, class T>
Sums group_sum(const CompiledMap::Tape& tape, std::size_t g, const T* mono) {
    constexpr std::size_t G = CompiledMap::group_width;
    Sums s0{}, s1{}, s2{}, s3{};
    const auto term = [&](std::uint32_t t, Sums& acc) {
        acc.template add<masked>(tape.group_coeff + std::size_t(t) * G, mono[tape.group_monomial[t]]);
    };
    std::uint32_t t = tape.group_start[g];
    const std::uint32_t end = tape.group_start[g + 1];
    for (; t + 4 <= end; t += 4) {
        term(t, s0);
        term(t + 1, s1);
        term(t + 2, s2);
        term(t + 3, s3);
    }
    for (; t < end; ++t) term(t, s0);
    return (s0 + s1) + (s2 + s3);
}

// Each group summed without masks first: where its four lanes come out finite, every monomial it read was finite, so
// each product a zero coefficient made was +-0, and a partial sum begun at +0 is never -0, so adding it changed
// nothing: the masked sum's bits. Otherwise (a non-finite monomial makes every lane inf or NaN, and none comes back)
// the group is summed again with masks. Lotka-Volterra's interpreted step at k = 12, dt = 0.14: 574-595 -> 525-540 ns.
template <class Sums, class T>
[[maybe_unused]] void eval_groups(const CompiledMap::Tape& tape, const T* mono, T* out) {
    constexpr std::size_t G = CompiledMap::group_width;
    for (std::size_t g = 0; g < tape.groups; ++g) {
        Sums s = group_sum<false, Sums>(tape, g, mono);
        if (!s.finite()) s = group_sum<true, Sums>(tape, g, mono);
        for (std::size_t i = 0; i < G; ++i)
            if (tape.group_output[g][i] != CompiledMap::no_output) out[tape.group_output[g][i]] = s[i];
    }
}

}  // namespace

}  // namespace pgi
