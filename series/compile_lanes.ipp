// The lane kernel of CompiledMap (series/compile.hpp): W points at once from a map's Tape. Included by
// series/compile.cpp (eval_batch, the x86-64 baseline) and by poisson/lane_step_avx2.cpp (the batch step on AVX2), so
// each compiles it for its own instruction set: internal linkage, and no std:: call (an inline std function compiled
// for AVX2 could be the copy the linker keeps for the whole program; tests/lane_isa.sh).
#pragma once
#include "series/compile.hpp"

namespace pgi {
namespace {

// W points ("lanes") at once: input v of lane w at in[v in_stride + w], output o at out[o out_stride + w],
// monomial k at mono[k W + w]. eval_with's operations, in its order, once per lane (the four partial sums
// and their final pairing included), so each lane gets exactly eval()'s bits; the loops over the lanes are
// the inner ones, of a fixed length, which the compiler vectorises. mono holds num_monomials() W doubles.
template <std::size_t W>
[[maybe_unused]] void eval_tape_lanes(const CompiledMap::Tape& tape, const double* __restrict in, std::size_t in_stride,
                                      double* __restrict out, std::size_t out_stride, double* __restrict mono) {
    for (std::size_t w = 0; w < W; ++w) mono[w] = 1.0;
    for (std::size_t v = 0; v < tape.inputs; ++v)
        for (std::size_t w = 0; w < W; ++w) mono[(v + 1) * W + w] = in[v * in_stride + w];
    double* made = mono + (1 + tape.inputs) * W;
    for (std::size_t k = 0; k < tape.products; ++k) {
        const double* a = mono + std::size_t(tape.left[k]) * W;
        const double* b = mono + std::size_t(tape.right[k]) * W;
        double product[W];  // read both rows before writing: no aliasing to fear, so the lanes vectorise
        for (std::size_t w = 0; w < W; ++w) product[w] = a[w] * b[w];
        for (std::size_t w = 0; w < W; ++w) made[k * W + w] = product[w];
    }
    // the rows as eval_with adds them (each lane the same operations), then the grouped outputs: their four partial
    // sums side by side over quads of terms, then the sums' tails (split_sums), without the zeros a group pads with.
    // Two loops, not one stream for both: GCC allocates the sixteen lane-pairs of partial sums to registers in the
    // first; in a single loop over the stream it spilled some and left stragglers scalar (the batch step 1.2x slower).
    const auto term = [mono](std::uint32_t m, double c, double* acc) {
        const double* a = mono + std::size_t(m) * W;
        for (std::size_t w = 0; w < W; ++w) acc[w] += c * a[w];
    };
    for (std::size_t o = 0; o < tape.outputs; ++o) {
        std::uint32_t t = tape.row_start[o];
        const std::uint32_t end = tape.row_start[o + 1];
        if (t == end && tape.lane_row[o].start != UINT32_MAX) continue;  // grouped: below
        double s0[W] = {}, s1[W] = {}, s2[W] = {}, s3[W] = {};
        for (; t + 4 <= end; t += 4) {
            term(tape.term_monomial[t], tape.term_coeff[t], s0);
            term(tape.term_monomial[t + 1], tape.term_coeff[t + 1], s1);
            term(tape.term_monomial[t + 2], tape.term_coeff[t + 2], s2);
            term(tape.term_monomial[t + 3], tape.term_coeff[t + 3], s3);
        }
        for (; t < end; ++t) term(tape.term_monomial[t], tape.term_coeff[t], s0);
        for (std::size_t w = 0; w < W; ++w) out[o * out_stride + w] = (s0[w] + s1[w]) + (s2[w] + s3[w]);
    }
    const double* c = tape.lane_coeff;
    const std::uint32_t* tm = tape.lane_monomial;
    for (std::size_t o = 0; o < tape.outputs; ++o) {
        const CompiledMap::LaneRow& row = tape.lane_row[o];
        if (row.start == UINT32_MAX) continue;
        double s0[W] = {}, s1[W] = {}, s2[W] = {}, s3[W] = {};
        std::uint32_t t = row.start;
        for (const std::uint32_t end = t + 4 * row.quads; t < end; t += 4) {
            term(tm[t], c[t], s0);
            term(tm[t + 1], c[t + 1], s1);
            term(tm[t + 2], c[t + 2], s2);
            term(tm[t + 3], c[t + 3], s3);
        }
        for (std::uint32_t i = 0; i < row.tail[0]; ++i, ++t) term(tm[t], c[t], s0);
        for (std::uint32_t i = 0; i < row.tail[1]; ++i, ++t) term(tm[t], c[t], s1);
        for (std::uint32_t i = 0; i < row.tail[2]; ++i, ++t) term(tm[t], c[t], s2);
        for (std::uint32_t i = 0; i < row.tail[3]; ++i, ++t) term(tm[t], c[t], s3);
        for (std::size_t w = 0; w < W; ++w) out[o * out_stride + w] = (s0[w] + s1[w]) + (s2[w] + s3[w]);
    }
}

}  // namespace
}  // namespace pgi
