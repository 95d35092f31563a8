// The lane kernel of CompiledMap (series/compile.hpp): W points at once from a map's Tape. Included by
// series/compile.cpp (eval_batch, the x86-64 baseline) and by poisson/lane_step_avx2.cpp (the batch step on AVX2), so
// each compiles it for its own instruction set: internal linkage, and no std:: call (an inline std function compiled
// for AVX2 could be the copy the linker keeps for the whole program; tests/lane_isa.sh).
#pragma once
#include "series/compile.hpp"

namespace pgi {
namespace {

template <std::size_t W>
void eval_tape_lanes(const CompiledMap::Tape& tape, const double* __restrict in, std::size_t in_stride,
                     double* __restrict out, std::size_t out_stride, double* __restrict mono,
                     double* __restrict cache = nullptr);

// A term's coefficient in lane w: one for every lane, or each lane's own.
inline double lane_value(double c, std::size_t) {
    return c;
}
inline double lane_value(const double* c, std::size_t w) {
    return c[w];
}

// The coefficients of a map with slow inputs (Tape::slow) in W lanes, from cache as CompiledMap::lane_cache_size lays
// it out: a row whose first value is 1 once the rest holds values (2 when one of them is 0: mask_vanishing_lanes has
// work then), the slow inputs' values they were evaluated at, the coefficients (slot-major, W each), the coefficient
// map's monomials. Evaluated again when the cache holds none or a lane's slow inputs differ from those it holds, bit
// for bit.
template <std::size_t W>
const double* lane_coefficients(const CompiledMap::Tape& tape, const double* __restrict in, std::size_t in_stride,
                                double* __restrict cache) {
    const CompiledMap::Tape k = tape.coefficients->tape();
    double* held = cache + W;
    double* values = held + tape.slow * W;
    double* mono = values + k.outputs * W;
    const double* slow_in = in + (tape.inputs - tape.slow) * in_stride;
    bool same = cache[0] == 1.0 || cache[0] == 2.0;
    for (std::size_t v = 0; v < tape.slow && same; ++v)
        for (std::size_t w = 0; w < W; ++w)
            same = same && __builtin_bit_cast(unsigned long long, slow_in[v * in_stride + w]) ==
                               __builtin_bit_cast(unsigned long long, held[v * W + w]);
    if (same) return values;
    for (std::size_t v = 0; v < tape.slow; ++v)
        for (std::size_t w = 0; w < W; ++w) held[v * W + w] = slow_in[v * in_stride + w];
    eval_tape_lanes<W>(k, held, W, values, W, mono);
    bool vanishes = false;
    for (std::size_t e = 0; e < k.outputs * W; ++e) vanishes = vanishes || values[e] == 0;
    cache[0] = vanishes ? 2.0 : 1.0;
    return values;
}

// The outputs from the monomials: row_coeff(t) and lane_coeff(t) give term t's coefficient (a double for every lane,
// or a pointer to each lane's). The rows as eval_with adds them (each lane the same operations), then the grouped
// outputs: their four partial sums side by side over quads of terms, then the sums' tails (split_sums), without the
// zeros a group pads with. Two loops, not one stream for both: GCC allocates the sixteen lane-pairs of partial sums
// to registers in the first; in a single loop over the stream it spilled some and left stragglers scalar (the batch
// step 1.2x slower).
template <std::size_t W, class RowCoeff, class LaneCoeff>
void sum_tape_lanes(const CompiledMap::Tape& tape, const double* __restrict mono, double* __restrict out,
                    std::size_t out_stride, RowCoeff row_coeff, LaneCoeff lane_coeff) {
    const auto term = [mono](std::uint32_t m, const auto& c, double* acc) {
        const double* a = mono + std::size_t(m) * W;
        for (std::size_t w = 0; w < W; ++w) acc[w] += lane_value(c, w) * a[w];
    };
    for (std::size_t o = 0; o < tape.outputs; ++o) {
        std::uint32_t t = tape.row_start[o];
        const std::uint32_t end = tape.row_start[o + 1];
        if (t == end && tape.lane_row[o].start != UINT32_MAX) continue;  // grouped: below
        double s0[W] = {}, s1[W] = {}, s2[W] = {}, s3[W] = {};
        for (; t + 4 <= end; t += 4) {
            term(tape.term_monomial[t], row_coeff(t), s0);
            term(tape.term_monomial[t + 1], row_coeff(t + 1), s1);
            term(tape.term_monomial[t + 2], row_coeff(t + 2), s2);
            term(tape.term_monomial[t + 3], row_coeff(t + 3), s3);
        }
        for (; t < end; ++t) term(tape.term_monomial[t], row_coeff(t), s0);
        for (std::size_t w = 0; w < W; ++w) out[o * out_stride + w] = (s0[w] + s1[w]) + (s2[w] + s3[w]);
    }
    const std::uint32_t* tm = tape.lane_monomial;
    for (std::size_t o = 0; o < tape.outputs; ++o) {
        const CompiledMap::LaneRow& row = tape.lane_row[o];
        if (row.start == UINT32_MAX) continue;
        double s0[W] = {}, s1[W] = {}, s2[W] = {}, s3[W] = {};
        std::uint32_t t = row.start;
        for (const std::uint32_t end = t + 4 * row.quads; t < end; t += 4) {
            term(tm[t], lane_coeff(t), s0);
            term(tm[t + 1], lane_coeff(t + 1), s1);
            term(tm[t + 2], lane_coeff(t + 2), s2);
            term(tm[t + 3], lane_coeff(t + 3), s3);
        }
        for (std::uint32_t i = 0; i < row.tail[0]; ++i, ++t) term(tm[t], lane_coeff(t), s0);
        for (std::uint32_t i = 0; i < row.tail[1]; ++i, ++t) term(tm[t], lane_coeff(t), s1);
        for (std::uint32_t i = 0; i < row.tail[2]; ++i, ++t) term(tm[t], lane_coeff(t), s2);
        for (std::uint32_t i = 0; i < row.tail[3]; ++i, ++t) term(tm[t], lane_coeff(t), s3);
        for (std::size_t w = 0; w < W; ++w) out[o * out_stride + w] = (s0[w] + s1[w]) + (s2[w] + s3[w]);
    }
}

// A map with slow inputs, after sum_tape_lanes: where an output came out infinite or NaN in a lane, eval() sums it
// again with the coefficients that vanish at that lane's slow inputs masked (an infinite monomial times one adds
// nothing: CompiledMap::masked_row, GroupSums), and so does this, in the same partial sums (a masked term adds +0 to a
// sum begun at +0, which is never -0: as if left out). A finite output read only finite monomials, which masking
// leaves as they are.
template <std::size_t W>
void mask_vanishing_lanes(const CompiledMap::Tape& tape, const double* __restrict mono, double* __restrict out,
                          std::size_t out_stride, const double* __restrict c) {
    for (std::size_t o = 0; o < tape.outputs; ++o) {
        double* y = out + o * out_stride;
        bool finite = true;
        for (std::size_t w = 0; w < W; ++w) finite = finite && __builtin_isfinite(y[w]);
        if (finite) continue;
        double s[4][W] = {};
        const auto add = [&](const std::uint32_t* monomial, const std::uint32_t* slot, std::uint32_t t, double* acc) {
            const double *a = mono + std::size_t(monomial[t]) * W, *k = c + std::size_t(slot[t]) * W;
            for (std::size_t w = 0; w < W; ++w) acc[w] += k[w] == 0 ? 0.0 : k[w] * a[w];
        };
        const CompiledMap::LaneRow& row = tape.lane_row[o];
        if (row.start == UINT32_MAX) {  // a row: its quads round the four sums, its tail into the first (eval_with)
            const std::uint32_t start = tape.row_start[o], end = tape.row_start[o + 1];
            const std::uint32_t quads = start + (end - start) / 4 * 4;
            for (std::uint32_t t = start; t < end; ++t)
                add(tape.term_monomial, tape.term_slot, t, s[t < quads ? (t - start) % 4 : 0]);
        } else {  // a grouped output's lane row: its quads, then each sum's tail
            std::uint32_t t = row.start;
            for (const std::uint32_t quads = t + 4 * row.quads; t < quads; ++t)
                add(tape.lane_monomial, tape.lane_slot, t, s[(t - row.start) % 4]);
            for (std::size_t sum = 0; sum < 4; ++sum)
                for (std::uint32_t i = 0; i < row.tail[sum]; ++i, ++t)
                    add(tape.lane_monomial, tape.lane_slot, t, s[sum]);
        }
        for (std::size_t w = 0; w < W; ++w)
            if (!__builtin_isfinite(y[w])) y[w] = (s[0][w] + s[1][w]) + (s[2][w] + s[3][w]);
    }
}

// W points ("lanes") at once: input v of lane w at in[v in_stride + w], output o at out[o out_stride + w],
// monomial k at mono[k W + w]. eval_with's operations, in its order, once per lane (the four partial sums
// and their final pairing included), so each lane gets exactly eval()'s bits; the loops over the lanes are
// the inner ones, of a fixed length, which the compiler vectorises. mono holds num_monomials() W doubles. A map with
// slow inputs reads its coefficients lane by lane from cache (lane_cache_size(W) doubles, kept by the caller for
// this map alone, or holding none: its first value neither 1 nor 2).
template <std::size_t W>
[[maybe_unused]] void eval_tape_lanes(const CompiledMap::Tape& tape, const double* __restrict in, std::size_t in_stride,
                                      double* __restrict out, std::size_t out_stride, double* __restrict mono,
                                      double* __restrict cache) {
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
    if (tape.slow == 0) {
        sum_tape_lanes<W>(
            tape, mono, out, out_stride, [&tape](std::uint32_t t) { return tape.term_coeff[t]; },
            [&tape](std::uint32_t t) { return tape.lane_coeff[t]; });
        return;
    }
    const double* c = lane_coefficients<W>(tape, in, in_stride, cache);
    sum_tape_lanes<W>(
        tape, mono, out, out_stride, [&tape, c](std::uint32_t t) { return c + std::size_t(tape.term_slot[t]) * W; },
        [&tape, c](std::uint32_t t) { return c + std::size_t(tape.lane_slot[t]) * W; });
    if (cache[0] == 2.0) mask_vanishing_lanes<W>(tape, mono, out, out_stride, c);
}

}  // namespace
}  // namespace pgi
