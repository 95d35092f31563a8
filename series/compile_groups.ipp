// CompiledMap::eval_with's groups of four outputs, written once over the type of their four partial sums: two
// pairs of SSE2 lanes and long double lanes (series/compile.cpp), one AVX2 vector (series/compile_avx2.cpp). A
// group's terms go round-robin into four partial sums (one running sum would wait on the adder at every term),
// paired as (s0 + s1) + (s2 + s3), as a row's. Internal linkage on purpose: each including file keeps its own copy,
// compiled for its target.
#pragma once
#include "series/compile.hpp"

namespace pgi {

namespace {

// Sums: a group's four lanes, value-initialised to +0; add(c, m) adds c[i] m to lane i where c[i] is not zero (a
// padding zero adds nothing, even times an infinite or NaN monomial); [i] reads lane i.
template <class Sums, class T>
[[maybe_unused]] void eval_groups(const CompiledMap::Tape& tape, const T* mono, T* out) {
    constexpr std::size_t G = CompiledMap::group_width;
    for (std::size_t g = 0; g < tape.groups; ++g) {
        Sums s0{}, s1{}, s2{}, s3{};
        const auto term = [&](std::uint32_t t, Sums& acc) { acc.add(tape.group_coeff + std::size_t(t) * G, mono[tape.group_monomial[t]]); };
        std::uint32_t t = tape.group_start[g];
        const std::uint32_t end = tape.group_start[g + 1];
        for (; t + 4 <= end; t += 4) {
            term(t, s0);
            term(t + 1, s1);
            term(t + 2, s2);
            term(t + 3, s3);
        }
        for (; t < end; ++t) term(t, s0);
        for (std::size_t i = 0; i < G; ++i)
            if (tape.group_output[g][i] != CompiledMap::no_output) out[tape.group_output[g][i]] = (s0[i] + s1[i]) + (s2[i] + s3[i]);
    }
}

}  // namespace

}  // namespace pgi
