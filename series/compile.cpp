#include "series/compile.hpp"

#include <flint/mpoly.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

namespace pgi {

namespace {

// The distinct exponent vectors (one entry per input) seen so far, numbered in order of arrival: a flat
// array of exponents and an open-addressing hash table of their numbers (a std::map of vectors cost
// most of a large build in allocations and comparisons).
class MonomialTable {
public:
    explicit MonomialTable(std::size_t k) : k_(k), slots_(1024, empty) {}
    const unsigned long* exponents(std::uint32_t id) const { return exps_.data() + std::size_t(id) * k_; }
    /// The number of e, and whether it is new.
    std::pair<std::uint32_t, bool> insert(const unsigned long* e) {
        if (2 * (count_ + 1) > slots_.size()) grow();
        std::size_t s = hash(e) & (slots_.size() - 1);
        for (; slots_[s] != empty; s = (s + 1) & (slots_.size() - 1))
            if (std::equal(e, e + k_, exponents(slots_[s]))) return {slots_[s], false};
        slots_[s] = static_cast<std::uint32_t>(count_++);
        exps_.insert(exps_.end(), e, e + k_);
        return {slots_[s], true};
    }
    std::uint32_t at(const unsigned long* e) const {
        for (std::size_t s = hash(e) & (slots_.size() - 1);; s = (s + 1) & (slots_.size() - 1))
            if (std::equal(e, e + k_, exponents(slots_[s]))) return slots_[s];
    }
    std::size_t count() const { return count_; }

private:
    static constexpr std::uint32_t empty = UINT32_MAX;
    std::size_t hash(const unsigned long* e) const {
        std::uint64_t h = 0x9e3779b97f4a7c15ull;
        for (std::size_t v = 0; v < k_; ++v) h = (h ^ e[v]) * 0xff51afd7ed558ccdull, h ^= h >> 32;
        return static_cast<std::size_t>(h);
    }
    void grow() {
        std::vector<std::uint32_t> old(2 * slots_.size(), empty);
        old.swap(slots_);
        for (std::uint32_t id : old) {
            if (id == empty) continue;
            std::size_t s = hash(exponents(id)) & (slots_.size() - 1);
            while (slots_[s] != empty) s = (s + 1) & (slots_.size() - 1);
            slots_[s] = id;
        }
    }
    std::size_t k_, count_ = 0;
    std::vector<unsigned long> exps_;
    std::vector<std::uint32_t> slots_;
};

// The double nearest to content * z (correctly rounded, as Rational::to_double): directly when numerator
// and denominator are exact doubles (IEEE division rounds correctly), through the exact rational otherwise.
double term_value(const fmpq_t content, const fmpz_t z) {
    constexpr slong exact = slong(1) << 53;
    const fmpz* num = fmpq_numref(content);
    const fmpz* den = fmpq_denref(content);
    slong product;
    if (fmpz_fits_si(num) && fmpz_fits_si(z) && fmpz_fits_si(den) && !__builtin_mul_overflow(fmpz_get_si(num), fmpz_get_si(z), &product) &&
        product > -exact && product < exact && fmpz_get_si(den) < exact)
        return static_cast<double>(product) / static_cast<double>(fmpz_get_si(den));
    Rational q;
    fmpq_mul_fmpz(q.get_mut(), content, z);
    return q.to_double();
}

}  // namespace

CompiledMap CompiledMap::build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs) {
    CompiledMap c;
    const std::size_t k = inputs.size();
    c.num_inputs_ = k;
    if (outputs.empty()) return c;
    const RingPtr& ring = outputs.front().ring();
    std::vector<long> slot(ring->size(), -1);  // ring variable -> input position
    for (std::size_t i = 0; i < k; ++i) slot.at(inputs[i]) = static_cast<long>(i);

    // Every monomial the outputs use, closed under "remove one unit of the first variable".
    MonomialTable table(k);
    std::vector<unsigned long> x(k, 0), y(k);
    table.insert(x.data());  // the constant monomial
    const mpoly_ctx_struct* minfo = ring->ctx()->zctx->minfo;
    std::vector<ulong> e(static_cast<std::size_t>(minfo->nvars));
    c.row_start_.push_back(0);
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        const fmpq_mpoly_struct* f = outputs[o].get();
        const fmpz_mpoly_struct* z = f->zpoly;
        const std::size_t words = mpoly_words_per_exp(z->bits, minfo);
        for (slong t = 0; t < z->length; ++t) {
            mpoly_get_monomial_ui(e.data(), z->exps + std::size_t(t) * words, z->bits, minfo);
            std::fill(x.begin(), x.end(), 0);
            for (std::size_t v = 0; v < ring->size(); ++v) {
                if (e[v] == 0) continue;
                if (slot[v] < 0)
                    throw std::invalid_argument("pgi::CompiledMap: output " + std::to_string(o) + " reads '" + ring->names()[v] +
                                                "', which is not an input");
                x[static_cast<std::size_t>(slot[v])] = e[v];
            }
            const double coeff = term_value(f->content, z->coeffs + t);
            // NOTE: never let a rational become an infinite double silently
            if (!std::isfinite(coeff))
                throw std::invalid_argument("a coefficient of " +
                                            std::to_string(fmpz_sizeinbase(fmpq_numref(outputs[o].term_coeff(std::size_t(t)).get()), 10)) +
                                            " digits in output " + std::to_string(o) + " is beyond the double range");
            const auto [id, fresh] = table.insert(x.data());
            c.term_monomial_.push_back(id);
            c.term_coeff_.push_back(coeff);
            if (!fresh) continue;
            y = x;
            for (auto v = y.begin();;) {  // the parents, until one is known
                v = std::find_if(v, y.end(), [](unsigned long d) { return d > 0; });
                --*v;
                if (!table.insert(y.data()).second) break;
            }
        }
        c.row_start_.push_back(static_cast<std::uint32_t>(c.term_coeff_.size()));
    }

    // Total degree first, so a monomial's parent (one degree less) is always numbered before it.
    const std::size_t count = table.count();
    std::vector<unsigned long> degree(count);
    for (std::uint32_t id = 0; id < count; ++id) degree[id] = std::accumulate(table.exponents(id), table.exponents(id) + k, 0ul);
    std::vector<std::uint32_t> order(count);
    std::iota(order.begin(), order.end(), 0u);
    // the same order on one word per monomial (degree, then the exponents in fields) when they fit in it
    const unsigned width = std::bit_width(std::max<unsigned long>(1, *std::max_element(degree.begin(), degree.end())));
    if (width * (k + 1) <= 64) {
        std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(count);
        for (std::uint32_t id = 0; id < count; ++id) {
            std::uint64_t key = degree[id];
            for (std::size_t v = 0; v < k; ++v) key = key << width | table.exponents(id)[v];
            keyed[id] = {key, id};
        }
        std::sort(keyed.begin(), keyed.end());
        for (std::uint32_t m = 0; m < count; ++m) order[m] = keyed[m].second;
    } else {
        std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
            if (degree[a] != degree[b]) return degree[a] < degree[b];
            return std::lexicographical_compare(table.exponents(a), table.exponents(a) + k, table.exponents(b), table.exponents(b) + k);
        });
    }
    std::vector<std::uint32_t> number(count);
    for (std::uint32_t m = 0; m < count; ++m) number[order[m]] = m;
    for (std::uint32_t m = 1; m < count; ++m) {
        std::copy(table.exponents(order[m]), table.exponents(order[m]) + k, y.begin());
        auto v = std::find_if(y.begin(), y.end(), [](unsigned long d) { return d > 0; });
        --*v;
        c.parent_.push_back(number[table.at(y.data())]);
        c.var_.push_back(static_cast<std::uint32_t>(v - y.begin()));
    }
    for (auto& id : c.term_monomial_) id = number[id];
    c.mono_.assign(c.num_monomials(), 0.0);
    return c;
}

template <class T>
void CompiledMap::eval_with(const T* in, T* out, T* mono) const {
    mono[0] = T(1);
    const std::size_t M = parent_.size();
    for (std::size_t m = 0; m < M; ++m) mono[m + 1] = mono[parent_[m]] * in[var_[m]];
    const std::size_t O = num_outputs();
    const double* c = term_coeff_.data();
    const std::uint32_t* tm = term_monomial_.data();
    for (std::size_t o = 0; o < O; ++o) {
        // four partial sums: one running sum would wait on the adder's latency at every term
        T s0 = 0, s1 = 0, s2 = 0, s3 = 0;
        std::uint32_t t = row_start_[o];
        const std::uint32_t end = row_start_[o + 1];
        for (; t + 4 <= end; t += 4) {
            s0 += T(c[t]) * mono[tm[t]];
            s1 += T(c[t + 1]) * mono[tm[t + 1]];
            s2 += T(c[t + 2]) * mono[tm[t + 2]];
            s3 += T(c[t + 3]) * mono[tm[t + 3]];
        }
        for (; t < end; ++t) s0 += T(c[t]) * mono[tm[t]];
        out[o] = (s0 + s1) + (s2 + s3);
    }
}

void CompiledMap::eval(const double* in, double* out) const { eval_with(in, out, mono_.data()); }

// W points ("lanes") at once: input v of lane w at in[v in_stride + w], output o at out[o out_stride + w],
// monomial k at mono[k W + w]. eval_with's operations, in its order, once per lane (the four partial sums
// and their final pairing included), so each lane gets exactly eval()'s bits; the loops over the lanes are
// the inner ones, of a fixed length, which the compiler vectorises.
template <std::size_t W>
void CompiledMap::eval_lanes(const double* __restrict in, std::size_t in_stride, double* __restrict out, std::size_t out_stride,
                             double* __restrict mono) const {
    for (std::size_t w = 0; w < W; ++w) mono[w] = 1.0;
    const std::size_t M = parent_.size();
    for (std::size_t k = 0; k < M; ++k) {
        const double* parent = mono + std::size_t(parent_[k]) * W;
        const double* v = in + std::size_t(var_[k]) * in_stride;
        double product[W];  // read both rows before writing: no aliasing to fear, so the lanes vectorise
        for (std::size_t w = 0; w < W; ++w) product[w] = parent[w] * v[w];
        std::copy(product, product + W, mono + (k + 1) * W);
    }
    const double* c = term_coeff_.data();
    const std::uint32_t* tm = term_monomial_.data();
    for (std::size_t o = 0; o < num_outputs(); ++o) {
        double s0[W] = {}, s1[W] = {}, s2[W] = {}, s3[W] = {};
        std::uint32_t t = row_start_[o];
        const std::uint32_t end = row_start_[o + 1];
        for (; t + 4 <= end; t += 4) {
            const double *a = mono + tm[t] * W, *b = mono + tm[t + 1] * W, *d = mono + tm[t + 2] * W, *e = mono + tm[t + 3] * W;
            for (std::size_t w = 0; w < W; ++w) {
                s0[w] += c[t] * a[w];
                s1[w] += c[t + 1] * b[w];
                s2[w] += c[t + 2] * d[w];
                s3[w] += c[t + 3] * e[w];
            }
        }
        for (; t < end; ++t) {
            const double* a = mono + tm[t] * W;
            for (std::size_t w = 0; w < W; ++w) s0[w] += c[t] * a[w];
        }
        for (std::size_t w = 0; w < W; ++w) out[o * out_stride + w] = (s0[w] + s1[w]) + (s2[w] + s3[w]);
    }
}

void CompiledMap::eval_batch(const double* in, double* out, std::size_t m, std::vector<double>& scratch) const {
    // Blocks of W lanes: the monomials of one block (W num_monomials() doubles) stay in cache whatever m is.
    constexpr std::size_t W = batch_lanes;
    const std::size_t M = num_monomials(), k = num_inputs_, O = num_outputs();
    if (scratch.size() < (M + k + O) * W) scratch.resize((M + k + O) * W);
    double* mono = scratch.data();
    std::size_t j = 0;
    for (; j + W <= m; j += W) eval_lanes<W>(in + j, m, out + j, m, mono);
    const std::size_t rest = m - j;
    if (rest == 0) return;
    double *tin = mono + M * W, *tout = tin + k * W;
    if (2 * rest < W) {  // a few points left: one at a time costs less than a padded block (eval's own code)
        for (; j < m; ++j) {
            for (std::size_t v = 0; v < k; ++v) tin[v] = in[v * m + j];
            eval_with(tin, tout, mono);
            for (std::size_t o = 0; o < O; ++o) out[o * m + j] = tout[o];
        }
        return;
    }
    // the last, partial block: its lanes padded with copies of its last point, only the real ones written
    for (std::size_t v = 0; v < k; ++v)
        for (std::size_t w = 0; w < W; ++w) tin[v * W + w] = in[v * m + j + std::min(w, rest - 1)];
    eval_lanes<W>(tin, W, tout, W, mono);
    for (std::size_t o = 0; o < O; ++o)
        for (std::size_t w = 0; w < rest; ++w) out[o * m + j + w] = tout[o * W + w];
}

void CompiledMap::eval(const long double* in, long double* out, std::vector<long double>& scratch) const {
    scratch.resize(num_monomials());
    eval_with(in, out, scratch.data());
}

}  // namespace pgi
