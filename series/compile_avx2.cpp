// CompiledMap::eval's groups in double as one AVX2 vector of four lanes (GroupVectors::avx2), compiled with -mavx2
// (CMakeLists.txt) and run only where the processor has AVX2 (CompiledMap::set_group_vectors). Each lane does what
// the SSE2 pairs of series/compile.cpp do (a product, masked where the coefficient is zero, then a sum; the same
// partial sums, series/compile_groups.ipp): the same bits. Only eval_groups_avx2 may come out of this file with AVX
// instructions: everything else it uses has internal linkage (ctest lane_isa checks the object).
#include "series/compile_groups.ipp"

namespace pgi {

namespace {

struct QuadSums {
    using Quad = double __attribute__((vector_size(32)));
    using Bits = long long __attribute__((vector_size(32)));
    Quad v{};
    template <bool masked>
    void add(const double* c, double m) {
        Quad a;
        __builtin_memcpy(&a, c, sizeof a);
        const Quad mm = {m, m, m, m}, zero = {0, 0, 0, 0};
        if constexpr (masked)
            v += Quad(Bits(a * mm) & Bits(a != zero));
        else
            v += a * mm;
    }
    QuadSums operator+(const QuadSums& o) const { return {v + o.v}; }
    bool finite() const {
        return __builtin_isfinite(v[0]) && __builtin_isfinite(v[1]) && __builtin_isfinite(v[2]) &&
               __builtin_isfinite(v[3]);
    }
    double operator[](std::size_t i) const { return v[i]; }
};

}  // namespace

void eval_groups_avx2(const CompiledMap::Tape& tape, const double* mono, double* out) {
    eval_groups<QuadSums>(tape, mono, out);
}

}  // namespace pgi
