// CompiledMap::eval's groups in double as one AVX2 vector of four lanes (GroupVectors::avx2), compiled with -mavx2
// (CMakeLists.txt) and run only where the processor has AVX2 (CompiledMap::set_group_vectors). Each lane does what
// the SSE2 pairs of series/compile.cpp do (a product, masked where the coefficient is zero, then a sum; the four
// partial sums paired as (s0 + s1) + (s2 + s3)): the same bits. Only eval_groups_avx2 may come out of this file with
// AVX instructions: it calls no inline function another file could also emit (ctest lane_isa checks the object).
#include "series/compile.hpp"

namespace pgi {

void eval_groups_avx2(const CompiledMap::Tape& tape, const double* mono, double* out) {
    using Quad = double __attribute__((vector_size(32)));
    using Bits = long long __attribute__((vector_size(32)));
    constexpr std::size_t G = CompiledMap::group_width;
    static_assert(G == 4, "a group is one vector of four lanes");
    const Quad zero = {0, 0, 0, 0};
    for (std::size_t g = 0; g < tape.groups; ++g) {
        Quad s0 = zero, s1 = zero, s2 = zero, s3 = zero;
        std::uint32_t t = tape.group_start[g];
        const std::uint32_t end = tape.group_start[g + 1];
        // acc += c m where c is not zero (a padding zero adds nothing, even times an infinite or NaN monomial)
        const auto term = [&](std::uint32_t i, Quad& acc) {
            Quad c;
            __builtin_memcpy(&c, tape.group_coeff + std::size_t(i) * G, sizeof c);
            const double m = mono[tape.group_monomial[i]];
            const Quad mm = {m, m, m, m};
            acc += Quad(Bits(c * mm) & Bits(c != zero));
        };
        for (; t + 4 <= end; t += 4) {
            term(t, s0);
            term(t + 1, s1);
            term(t + 2, s2);
            term(t + 3, s3);
        }
        for (; t < end; ++t) term(t, s0);
        const Quad sum = (s0 + s1) + (s2 + s3);
        for (std::size_t i = 0; i < G; ++i)
            if (tape.group_output[g][i] != CompiledMap::no_output) out[tape.group_output[g][i]] = sum[i];
    }
}

}  // namespace pgi
