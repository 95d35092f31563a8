#include "series/compile.hpp"
#include "series/compile_groups.ipp"
#include "series/compile_lanes.ipp"

#include <flint/mpoly.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <iterator>
#include <span>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <numeric>
#include <unordered_map>
#include <stdexcept>

namespace pgi {

// The groups of eval() in double on AVX2 (series/compile_avx2.cpp, compiled for it): GroupSums' operations, lane by
// lane.
void eval_groups_avx2(const CompiledMap::Tape& tape, const double* mono, double* out);

namespace {

// A monomial in the inputs: its (input, exponent) pairs, inputs ascending, every exponent positive (the
// constant monomial has none). Sparse, so that a map of a thousand inputs stores each monomial in the
// size of its own support, not in k words.
struct Power {
    std::uint32_t input, exponent;
    bool operator==(const Power&) const = default;
};
using Exponents = std::span<const Power>;

std::size_t total_degree(Exponents e) {
    std::size_t d = 0;
    for (const Power& p : e) d += p.exponent;
    return d;
}

// The distinct monomials seen so far, numbered in order of arrival: a flat array of their powers and an
// open-addressing hash table of their numbers (a std::map of vectors cost most of a large build in
// allocations and comparisons).
class MonomialTable {
public:
    MonomialTable() : slots_(1024, empty), start_{0} {}
    Exponents exponents(std::uint32_t id) const {
        return {powers_.data() + start_[id], powers_.data() + start_[id + 1]};
    }
    std::size_t count() const { return start_.size() - 1; }
    /// The number of e, and whether it is new.
    std::pair<std::uint32_t, bool> insert(Exponents e) {
        if (2 * (count() + 1) > slots_.size()) grow();
        std::size_t s = slot_of(e);
        if (slots_[s] != empty) return {slots_[s], false};
        slots_[s] = static_cast<std::uint32_t>(count());
        powers_.insert(powers_.end(), e.begin(), e.end());
        start_.push_back(powers_.size());
        return {slots_[s], true};
    }
    /// The number of e, or none.
    std::uint32_t find(Exponents e) const { return slots_[slot_of(e)]; }
    static constexpr std::uint32_t none = UINT32_MAX;

private:
    static constexpr std::uint32_t empty = none;
    static std::size_t hash(Exponents e) {
        std::uint64_t h = 0x9e3779b97f4a7c15ull;
        for (const Power& p : e)
            h = (h ^ (std::uint64_t(p.input) << 32 | p.exponent)) * 0xff51afd7ed558ccdull, h ^= h >> 32;
        return static_cast<std::size_t>(h);
    }
    // e's slot, or the empty one where it would go
    std::size_t slot_of(Exponents e) const {
        std::size_t s = hash(e) & (slots_.size() - 1);
        for (; slots_[s] != empty; s = (s + 1) & (slots_.size() - 1)) {
            const Exponents f = exponents(slots_[s]);
            if (std::equal(e.begin(), e.end(), f.begin(), f.end())) break;
        }
        return s;
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
    std::vector<std::uint32_t> slots_;
    std::vector<Power> powers_;
    std::vector<std::size_t> start_;  // monomial id's powers are powers_[start_[id], start_[id + 1])
};

// The monomials the terms read, each made as the product of two made before it (a vectorial addition chain):
// the constant is monomial 0 and the inputs 1..k; a monomial t is split as a + b with both made when some
// divisor allows it (split), else as its largest made divisor a times the rest t - a, made first the same way,
// when a has at least half t's degree, else as h + (t - h) with h = floor(t / 2), both made first (a power x^d
// then takes about 2 log2 d products, not d - 1). On sparse polynomials (the rigid body's S_dt is a polynomial
// in squares) this makes far fewer monomials than "one variable times a monomial of one degree less", whose
// intermediate chains cost more than the terms; on dense ones it is that rule.
class MonomialChain {
public:
    explicit MonomialChain(std::size_t k) {
        made_.insert({});
        for (std::uint32_t v = 0; v < k; ++v) {
            const Power e{v, 1};
            made_.insert(Exponents(&e, 1));
        }
    }
    /// t's number in the chain, made (with what it needs) if new.
    std::uint32_t make(Exponents t) {
        if (const auto id = made_.find(t); id != MonomialTable::none) return id;
        const std::vector<Power> whole(t.begin(), t.end());
        Split s = split(whole);
        if (s.b == MonomialTable::none) {
            std::vector<Power> half, other;  // h = floor(t / 2) and t - h
            for (const Power& p : whole) {
                if (p.exponent / 2 > 0) half.push_back({p.input, p.exponent / 2});
                other.push_back({p.input, p.exponent - p.exponent / 2});
            }
            if (2 * s.a_degree >= total_degree(whole) || half.empty()) {
                s.b = make(s.rest);
            } else {  // no made divisor of half t's degree: powers by squaring
                s.a = make(half);
                s.b = make(other);
            }
        }
        const std::uint32_t id = made_.insert(whole).first;
        factors_.push_back({s.a, s.b});
        return id;
    }
    /// Monomial k + 1 + m = monomial factors()[m].first * monomial factors()[m].second.
    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& factors() const { return factors_; }

private:
    struct Split {
        std::uint32_t a = MonomialTable::none, b = MonomialTable::none;
        std::size_t a_degree = 0;
        std::vector<Power> rest;  // t - a when b is none
    };
    // At most this many divisors are tried per monomial, after the one-input-less ones; past it, the best made
    // divisor found so far is used. The search is the build's cost on large maps: `pgi step volterra_chain.toml
    // --realisation radial --order 8 --dt 0.2` took 12.8 s with a limit of 4096 and no one-input-less pass (two
    // thirds of it here), 5.6 s at 64, 4.9 s at 16 (32d42f9, one input at a time: 9.4 s and 527 MB, now 218 MB);
    // the bundled scenes' maps come out the same at 16.
    static constexpr std::size_t divisor_limit = 16;

    // A split of t (of degree 2 or more) into two made monomials: t - e_v times the input v where t - e_v is made
    // (dense polynomials: one lookup per input held), else the first of t's divisors, taken in a fixed order, whose
    // complement is made too; failing that, t's made divisor of the highest degree as a (b none, rest = t - a). The
    // first divisor tried is t's first input, which is made: the best starts there.
    Split split(const std::vector<Power>& t) const {
        std::vector<Power> less = t;
        for (std::size_t i = 0; i < t.size(); ++i) {
            if (--less[i].exponent == 0) less.erase(less.begin() + std::ptrdiff_t(i));
            if (const std::uint32_t id = made_.find(less); id != MonomialTable::none)
                return {id, 1 + t[i].input, 0, {}};
            less = t;
        }
        const std::size_t degree = total_degree(t);
        std::vector<std::uint32_t> e(t.size(), 0);  // the divisor's exponents, a mixed-radix counter
        std::vector<Power> a, b;
        Split best{};
        std::size_t best_degree = 0, tried = 0;
        while (tried++ < divisor_limit) {
            std::size_t i = 0;  // next divisor
            for (; i < t.size() && e[i] == t[i].exponent; ++i) e[i] = 0;
            if (i == t.size()) break;
            ++e[i];
            a.clear();
            b.clear();
            std::size_t da = 0;
            for (std::size_t j = 0; j < t.size(); ++j) {
                if (e[j] > 0) a.push_back({t[j].input, e[j]});
                if (e[j] < t[j].exponent) b.push_back({t[j].input, t[j].exponent - e[j]});
                da += e[j];
            }
            if (da == degree) continue;  // t itself
            const std::uint32_t ia = made_.find(a);
            if (ia == MonomialTable::none) continue;
            if (const std::uint32_t ib = made_.find(b); ib != MonomialTable::none) return Split{ia, ib, 0, {}};
            if (da > best_degree) best = Split{ia, MonomialTable::none, da, b}, best_degree = da;
        }
        return best;
    }

    MonomialTable made_;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> factors_;
};

// The double nearest to content * z (correctly rounded, as Rational::to_double): directly when numerator
// and denominator are exact doubles (IEEE division rounds correctly), through the exact rational otherwise.
double term_value(const fmpq_t content, const fmpz_t z) {
    constexpr slong exact = slong(1) << 53;
    const fmpz* num = fmpq_numref(content);
    const fmpz* den = fmpq_denref(content);
    slong product;
    if (fmpz_fits_si(num) && fmpz_fits_si(z) && fmpz_fits_si(den) &&
        !__builtin_mul_overflow(fmpz_get_si(num), fmpz_get_si(z), &product) && product > -exact && product < exact &&
        fmpz_get_si(den) < exact)
        return static_cast<double>(product) / static_cast<double>(fmpz_get_si(den));
    Rational q;
    fmpq_mul_fmpz(q.get_mut(), content, z);
    return q.to_double();
}

}  // namespace

namespace {

// Every term of outputs, in FLINT's order: term(o, its monomial over the input positions (ascending), its
// coefficient), then row_end(o) after output o's.
template <class Term, class RowEnd>
void read_terms(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs, Term term, RowEnd row_end) {
    const RingPtr& ring = outputs.front().ring();
    std::vector<long> slot(ring->size(), -1);  // ring variable -> input position
    for (std::size_t i = 0; i < inputs.size(); ++i) slot.at(inputs[i]) = static_cast<long>(i);
    std::vector<ulong> e;
    std::vector<Power> x;
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        if (outputs[o].ring() != ring)
            throw std::invalid_argument("pgi::CompiledMap: the outputs belong to different rings");
        const fmpq_mpoly_struct* f = outputs[o].get();
        const fmpz_mpoly_struct* z = f->zpoly;
        const mpoly_ctx_struct* minfo = outputs[o].ctx()->zctx->minfo;
        const auto vars = outputs[o].variables();  // the exponent vectors run over these
        e.resize(static_cast<std::size_t>(minfo->nvars));
        const std::size_t words = mpoly_words_per_exp(z->bits, minfo);
        for (slong t = 0; t < z->length; ++t) {
            if (z->bits > FLINT_BITS)
                throw std::invalid_argument("pgi::CompiledMap: output " + std::to_string(o) +
                                            " has a power above 2^64");
            mpoly_get_monomial_ui(e.data(), z->exps + std::size_t(t) * words, z->bits, minfo);
            x.clear();
            for (std::size_t j = 0; j < vars.size(); ++j) {
                const std::size_t v = vars[j];
                if (e[j] == 0) continue;
                if (slot[v] < 0)
                    throw std::invalid_argument("pgi::CompiledMap: output " + std::to_string(o) + " reads '" +
                                                ring->names()[v] + "', which is not an input");
                if (e[j] > UINT32_MAX)
                    throw std::invalid_argument("pgi::CompiledMap: output " + std::to_string(o) +
                                                " has a power above 2^32");
                x.push_back({static_cast<std::uint32_t>(slot[v]), static_cast<std::uint32_t>(e[j])});
            }
            std::sort(x.begin(), x.end(), [](const Power& a, const Power& b) { return a.input < b.input; });
            const double coeff = term_value(f->content, z->coeffs + t);
            // NOTE: never let a rational become an infinite double silently
            if (!std::isfinite(coeff))
                throw std::invalid_argument(
                    "a coefficient of " +
                    std::to_string(fmpz_sizeinbase(fmpq_numref(outputs[o].term_coeff(std::size_t(t)).get()), 10)) +
                    " digits in output " + std::to_string(o) + " is beyond the double range");
            term(o, Exponents(x), coeff);
        }
        row_end(o);
    }
}

// How the targets are made: made[target] is its monomial's number, monomial 1 + k + m is the product of monomials
// left[m] and right[m].
struct Chain {
    std::vector<std::uint32_t> made, left, right;
};

// The targets made by increasing degree (in order of arrival within a degree), so that the lower ones are there to
// split the higher; the products then by level (an input is at level 0, a product one above its higher factor), in
// the order of the chain within a level: a product then never waits on the one just before it (its store and the
// multiplication's latency), so the products of a level overlap. (Not storing a product that one term alone reads,
// the term multiplying its two factors itself, measured slower: every term pays one more load.)
Chain chain_of(const MonomialTable& targets, std::size_t k) {
    std::vector<std::uint32_t> by_degree(targets.count());
    std::iota(by_degree.begin(), by_degree.end(), 0u);
    std::stable_sort(by_degree.begin(), by_degree.end(), [&](std::uint32_t a, std::uint32_t b) {
        return total_degree(targets.exponents(a)) < total_degree(targets.exponents(b));
    });
    MonomialChain chain(k);
    Chain c;
    c.made.resize(targets.count());
    for (std::uint32_t id : by_degree) c.made[id] = chain.make(targets.exponents(id));
    const auto& factors = chain.factors();
    const std::size_t first = 1 + k;
    std::vector<std::uint32_t> level(first + factors.size(), 0);
    for (std::size_t m = 0; m < factors.size(); ++m)
        level[first + m] = 1 + std::max(level[factors[m].first], level[factors[m].second]);
    std::vector<std::uint32_t> order(factors.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return level[first + a] < level[first + b]; });
    std::vector<std::uint32_t> number(first + factors.size());
    std::iota(number.begin(), number.begin() + std::ptrdiff_t(first), 0u);
    for (std::size_t m = 0; m < order.size(); ++m) number[first + order[m]] = static_cast<std::uint32_t>(first + m);
    for (std::uint32_t m : order) {
        c.left.push_back(number[factors[m].first]);
        c.right.push_back(number[factors[m].second]);
    }
    for (auto& id : c.made) id = number[id];
    return c;
}

}  // namespace

void CompiledMap::finish(const std::vector<std::uint32_t>& made, std::vector<std::uint32_t> left,
                         std::vector<std::uint32_t> right) {
    static std::atomic<std::uint64_t> builds{0};
    serial_ = ++builds;
    for (auto& id : term_monomial_) id = made[id];
    left_ = std::move(left);
    right_ = std::move(right);
    group_outputs();
    split_sums();
    set_group_vectors(GroupVectors::automatic);
    mono_.assign(num_monomials(), 0.0);
}

CompiledMap CompiledMap::build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs) {
    CompiledMap c;
    c.num_inputs_ = inputs.size();
    if (outputs.empty()) return c;
    MonomialTable targets;  // every term's monomial, numbered in order of arrival
    c.row_start_.push_back(0);
    read_terms(
        outputs, inputs,
        [&](std::size_t, Exponents x, double coeff) {
            c.term_monomial_.push_back(targets.insert(x).first);
            c.term_coeff_.push_back(coeff);
        },
        [&](std::size_t) { c.row_start_.push_back(static_cast<std::uint32_t>(c.term_coeff_.size())); });
    Chain chain = chain_of(targets, inputs.size());
    c.finish(chain.made, std::move(chain.left), std::move(chain.right));
    return c;
}

// Two stages: output o's terms are gathered by their monomial in the other inputs (the fast ones), each such
// (output, monomial) a slot whose coefficient is the polynomial in the slow inputs its terms make. The fast map is
// built with slot + 1 as each coefficient (exact in double, never zero), so that its groups and lane rows, laid out
// as for any map, say which slot each of their coefficients is (take_slots); the slots' polynomials are the
// coefficient map's rows.
CompiledMap CompiledMap::build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs,
                               std::size_t slow) {
    if (slow > inputs.size()) throw std::invalid_argument("pgi::CompiledMap: more slow inputs than inputs");
    if (slow == 0 || outputs.empty()) return build(outputs, inputs);
    const std::size_t k = inputs.size(), fast = k - slow;
    CompiledMap c, K;
    c.num_inputs_ = k;
    K.num_inputs_ = slow;
    struct SlotTerm {
        std::uint32_t slot, monomial;
        double coeff;
    };
    std::vector<SlotTerm> slot_terms;
    MonomialTable targets, slow_targets;
    std::unordered_map<std::uint32_t, std::uint32_t> slot_of;  // this output's fast monomials -> their slots
    std::vector<Power> xf, xs;
    std::uint32_t slots = 0;
    c.row_start_.push_back(0);
    read_terms(
        outputs, inputs,
        [&](std::size_t, Exponents x, double coeff) {
            xf.clear(), xs.clear();
            for (const Power& p : x)
                if (p.input < fast)
                    xf.push_back(p);
                else
                    xs.push_back({static_cast<std::uint32_t>(p.input - fast), p.exponent});
            const auto [at, is_new] = slot_of.try_emplace(targets.insert(xf).first, slots);
            if (is_new) {
                c.term_monomial_.push_back(at->first);
                c.term_coeff_.push_back(double(slots++) + 1);
            }
            slot_terms.push_back({at->second, slow_targets.insert(xs).first, coeff});
        },
        [&](std::size_t) {
            c.row_start_.push_back(static_cast<std::uint32_t>(c.term_coeff_.size()));
            slot_of.clear();
        });
    std::stable_sort(slot_terms.begin(), slot_terms.end(),
                     [](const SlotTerm& a, const SlotTerm& b) { return a.slot < b.slot; });
    K.row_start_.assign(slots + 1, 0);
    for (const SlotTerm& t : slot_terms) {
        ++K.row_start_[t.slot + 1];
        K.term_monomial_.push_back(t.monomial);
        K.term_coeff_.push_back(t.coeff);
    }
    for (std::size_t s = 0; s < slots; ++s) K.row_start_[s + 1] += K.row_start_[s];
    Chain kc = chain_of(slow_targets, slow);
    K.finish(kc.made, std::move(kc.left), std::move(kc.right));
    Chain chain = chain_of(targets, k);
    c.finish(chain.made, std::move(chain.left), std::move(chain.right));
    c.slow_ = slow;
    c.coefficients_.emplace(std::move(K));
    c.take_slots();
    return c;
}

// The slots the built coefficients name (slot + 1; a group's padding 0 names none).
void CompiledMap::take_slots() {
    const auto slots = [](const std::vector<double>& coeff) {
        std::vector<std::uint32_t> s(coeff.size());
        for (std::size_t t = 0; t < coeff.size(); ++t)
            s[t] = coeff[t] == 0 ? no_output : static_cast<std::uint32_t>(coeff[t]) - 1;
        return s;
    };
    term_slot_ = slots(term_coeff_);
    group_slot_ = slots(group_coeff_);
    lane_slot_ = slots(lane_coeff_);
    slot_values_.assign(coefficients_->num_outputs(), 0.0);
    bound_.assign(slow_, 0.0);
    bound_any_ = false;
}

// The coefficients at the slow inputs' values slow, unless they hold them already (bit for bit).
void CompiledMap::bind(const double* slow) const {
    if (bound_any_ && std::memcmp(slow, bound_.data(), slow_ * sizeof(double)) == 0) return;
    coefficients_->eval(slow, slot_values_.data());
    const auto set = [this](const std::vector<std::uint32_t>& slots, std::vector<double>& coeff) {
        for (std::size_t t = 0; t < slots.size(); ++t) coeff[t] = slots[t] == no_output ? 0.0 : slot_values_[slots[t]];
    };
    set(term_slot_, term_coeff_);
    row_vanishes_ = std::find(term_coeff_.begin(), term_coeff_.end(), 0.0) != term_coeff_.end();
    set(group_slot_, group_coeff_);
    set(lane_slot_, lane_coeff_);
    std::copy(slow, slow + slow_, bound_.begin());
    bound_any_ = true;
}

std::size_t CompiledMap::lane_cache_size(std::size_t lanes) const {
    if (slow_ == 0) return 0;
    return (1 + slow_ + coefficients_->num_outputs() + coefficients_->num_monomials()) * lanes;
}

double* LaneCoefficients::get(const CompiledMap& map, std::size_t blocks) {
    auto e = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& x) { return x.serial == map.serial_; });
    if (e == entries_.end()) {
        if (entries_.size() == max_entries) entries_.erase(entries_.begin());  // (the oldest: its map is likely gone)
        e = entries_.insert(entries_.end(), Entry{map.serial_, {}});
    }
    const std::size_t block = map.lane_cache_size(CompiledMap::batch_lanes);
    if (e->cache.size() < (first_ + blocks) * block)
        e->cache.resize((first_ + blocks) * block, 0.0);  // (a new block's first value 0: it holds none)
    return e->cache.data() + first_ * block;
}

bool processor_has_avx2() {
    return __builtin_cpu_supports("avx2");
}

std::size_t CompiledMap::saved_by_fours() const {
    std::size_t saved = 0;
    // (with slow inputs, the structure's zeros: the slots', whatever values the coefficients hold now)
    const auto nonzero = [this](std::size_t i) { return slow_ ? group_slot_[i] != no_output : group_coeff_[i] != 0; };
    for (std::size_t t = 0; t < group_monomial_.size(); ++t) {
        const std::size_t i = group_width * t;
        saved += (nonzero(i) || nonzero(i + 1)) && (nonzero(i + 2) || nonzero(i + 3));
    }
    return saved;
}

void CompiledMap::set_group_vectors(GroupVectors v) {
    if (v == GroupVectors::avx2 && !processor_has_avx2())
        throw std::invalid_argument("CompiledMap: AVX2 group sums asked on a processor without AVX2");
    fours_ = v == GroupVectors::avx2 || (v == GroupVectors::automatic && processor_has_avx2() && fours_pay());
}

// The lane kernel's terms of a grouped output (eval_tape_lanes, series/compile_lanes.ipp): which of eval_with's
// four partial sums each goes into (the term at position p of its group's union of length L goes into sum p mod 4,
// the last L mod 4 into sum 0, as a row's; the padding zeros into none), laid out in one stream: quads (sum 0, 1,
// 2, 3) while every sum has terms, then what is left of sum 0, 1, 2 and 3.
void CompiledMap::split_sums() {
    const std::size_t O = num_outputs();
    lane_row_.assign(O, LaneRow{UINT32_MAX, 0, {}});  // not grouped: the lane kernel reads the row
    const auto sum_of = [](std::size_t p, std::size_t L) { return p < L / 4 * 4 ? p % 4 : 0; };
    for (std::size_t g = 0; g < group_output_.size(); ++g) {
        const std::size_t L = group_start_[g + 1] - group_start_[g];
        for (std::size_t i = 0; i < group_width; ++i) {
            const std::uint32_t o = group_output_[g][i];
            if (o == no_output) continue;
            std::vector<std::pair<std::uint32_t, double>> sums[4];
            for (std::size_t p = 0; p < L; ++p) {
                const std::size_t t = group_start_[g] + p;
                if (group_coeff_[t * group_width + i] != 0)
                    sums[sum_of(p, L)].push_back({group_monomial_[t], group_coeff_[t * group_width + i]});
            }
            LaneRow row{static_cast<std::uint32_t>(lane_coeff_.size()), UINT32_MAX, {}};
            for (const auto& sum : sums) row.quads = std::min(row.quads, static_cast<std::uint32_t>(sum.size()));
            const auto put = [&](const std::pair<std::uint32_t, double>& term) {
                lane_monomial_.push_back(term.first), lane_coeff_.push_back(term.second);
            };
            for (std::size_t q = 0; q < row.quads; ++q)
                for (const auto& sum : sums) put(sum[q]);
            for (std::size_t a = 0; a < 4; ++a) {
                row.tail[a] = static_cast<std::uint32_t>(sums[a].size()) - row.quads;
                for (std::size_t q = row.quads; q < sums[a].size(); ++q) put(sums[a][q]);
            }
            lane_row_[o] = row;
        }
    }
}

// A group's four partial sums in double: two pairs of lanes (GCC's vector extension, SSE2 on x86-64), each
// lane's operations those of the scalar code (a product, then a sum).
namespace {
struct GroupSums {
    using Pair = double __attribute__((vector_size(16)));
    Pair lo{}, hi{};
    using Bits = long long __attribute__((vector_size(16)));
    // acc += c m; masked: where c is not zero (a padding zero adds +0, which leaves a sum that started at +0 as it
    // is, even where m is infinite or NaN: the lane kernel skips those terms, and the bits agree)
    template <bool masked>
    void add(const double* c, double m) {
        Pair a, b;
        std::memcpy(&a, c, sizeof a);
        std::memcpy(&b, c + 2, sizeof b);
        const Pair mm = {m, m}, zero = {0, 0};
        if constexpr (masked) {
            lo += Pair(Bits(a * mm) & Bits(a != zero));
            hi += Pair(Bits(b * mm) & Bits(b != zero));
        } else {
            lo += a * mm;
            hi += b * mm;
        }
    }
    GroupSums operator+(const GroupSums& o) const { return {lo + o.lo, hi + o.hi}; }
    bool finite() const {
        return std::isfinite(lo[0]) && std::isfinite(lo[1]) && std::isfinite(hi[0]) && std::isfinite(hi[1]);
    }
    double operator[](std::size_t i) const { return i < 2 ? lo[i] : hi[i - 2]; }
};
// The same in long double (reference evaluations), one lane at a time; its zero coefficients always skipped.
template <class T>
struct ScalarSums {
    std::array<T, CompiledMap::group_width> v{};
    template <bool>
    void add(const double* c, T m) {
        for (std::size_t i = 0; i < v.size(); ++i)
            if (c[i] != 0) v[i] += T(c[i]) * m;
    }
    ScalarSums operator+(const ScalarSums& o) const {
        ScalarSums s;
        for (std::size_t i = 0; i < v.size(); ++i) s.v[i] = v[i] + o.v[i];
        return s;
    }
    bool finite() const { return true; }  // (never multiplied a zero coefficient: nothing to redo)
    T operator[](std::size_t i) const { return v[i]; }
};
}  // namespace

// Outputs that read mostly the same monomials are evaluated four at a time: one pass over the union of their
// monomials, each read once and multiplied by a vector of four coefficients (zero where an output lacks the
// monomial). A group is kept when its union, at group_cost scalar terms per grouped one, costs less than its
// outputs' terms one by one (1.25, 1.5 and 2 measured on the bundled scenes at k = 10: 2 best; a grouped term is
// twice the arithmetic of a scalar one, but one index and one monomial load for four). Lotka-Volterra's grad and
// Hess S_dt at k = 10: 846 terms and monomials to 466, the step 1.2x faster; the rigid body's grad S_dt shares
// nothing (parities) and stays as it is. A padding zero adds nothing, even times an infinite monomial
// (GroupSums masks it; the lane kernel skips it). Only maps of at most group_limit outputs are grouped (the greedy
// choice is quadratic in the outputs; a lattice's maps are sparse and gain nothing).
void CompiledMap::group_outputs() {
    constexpr double group_cost = 2.0;
    constexpr std::size_t group_limit = 64;
    const std::size_t O = num_outputs();
    if (O < 2 || O > group_limit) return;
    const auto row = [&](std::size_t o) {
        std::vector<std::uint32_t> m(term_monomial_.begin() + row_start_[o],
                                     term_monomial_.begin() + row_start_[o + 1]);
        std::sort(m.begin(), m.end());
        return m;
    };
    std::vector<std::vector<std::uint32_t>> rows(O);
    for (std::size_t o = 0; o < O; ++o) rows[o] = row(o);
    const auto shared = [](const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
        std::size_t n = 0;
        for (std::size_t i = 0, j = 0; i < a.size() && j < b.size();) {
            if (a[i] < b[j])
                ++i;
            else if (b[j] < a[i])
                ++j;
            else
                ++n, ++i, ++j;
        }
        return n;
    };
    std::vector<bool> taken(O, false);
    std::vector<std::array<std::uint32_t, group_width>> groups;
    std::vector<std::vector<std::uint32_t>> unions;  // each group's monomials, ascending
    for (std::size_t seed = 0; seed < O; ++seed) {
        if (taken[seed] || rows[seed].empty()) continue;
        std::vector<std::size_t> members{seed};
        std::vector<std::uint32_t> u = rows[seed];
        std::size_t alone = rows[seed].size();
        while (members.size() < group_width) {  // the free output sharing the largest part of itself with the union
            std::size_t best = O;
            double best_part = 0;
            for (std::size_t o = seed + 1; o < O; ++o) {
                if (taken[o] || rows[o].empty() || std::find(members.begin(), members.end(), o) != members.end())
                    continue;
                const double part = double(shared(rows[o], u)) / double(rows[o].size());
                if (part > best_part) best = o, best_part = part;
            }
            if (best == O) break;
            members.push_back(best);
            alone += rows[best].size();
            std::vector<std::uint32_t> merged;
            std::set_union(u.begin(), u.end(), rows[best].begin(), rows[best].end(), std::back_inserter(merged));
            u = std::move(merged);
        }
        if (members.size() < 2 || group_cost * double(u.size()) >= double(alone)) continue;
        std::array<std::uint32_t, group_width> g;
        g.fill(no_output);
        for (std::size_t i = 0; i < members.size(); ++i)
            g[i] = static_cast<std::uint32_t>(members[i]), taken[members[i]] = true;
        groups.push_back(g);
        unions.push_back(std::move(u));
    }
    if (groups.empty()) return;
    // the grouped terms, each group's in the order of its union (monomial numbers ascending), then from the highest
    // degree down
    const std::vector<std::uint32_t> degree = monomial_degrees();
    group_start_.push_back(0);
    for (std::size_t n = 0; n < groups.size(); ++n) {
        const auto& g = groups[n];
        const auto& u = unions[n];
        const std::size_t first = group_monomial_.size();
        group_monomial_.insert(group_monomial_.end(), u.begin(), u.end());
        group_coeff_.resize(group_monomial_.size() * group_width, 0.0);
        for (std::size_t i = 0; i < group_width; ++i) {
            if (g[i] == no_output) continue;
            for (std::uint32_t t = row_start_[g[i]]; t < row_start_[g[i] + 1]; ++t) {
                const std::size_t at =
                    first + std::size_t(std::lower_bound(u.begin(), u.end(), term_monomial_[t]) - u.begin());
                group_coeff_[at * group_width + i] +=
                    term_coeff_[t];  // one term per monomial: FLINT's terms are distinct
            }
        }
        order_from_highest_degree(first, degree);
        group_start_.push_back(static_cast<std::uint32_t>(group_monomial_.size()));
        group_output_.push_back(g);
    }
    // the grouped outputs' own rows emptied
    std::vector<bool> grouped(O, false);
    for (const auto& g : groups)
        for (std::uint32_t o : g)
            if (o != no_output) grouped[o] = true;
    std::vector<std::uint32_t> start{0}, monomial;
    std::vector<double> coeff;
    for (std::size_t o = 0; o < O; ++o) {
        if (!grouped[o])
            for (std::uint32_t t = row_start_[o]; t < row_start_[o + 1]; ++t)
                monomial.push_back(term_monomial_[t]), coeff.push_back(term_coeff_[t]);
        start.push_back(static_cast<std::uint32_t>(coeff.size()));
    }
    row_start_ = std::move(start);
    term_monomial_ = std::move(monomial);
    term_coeff_ = std::move(coeff);
}

// The total degree of each monomial: 0 for the constant, 1 for an input, a product's its factors' sum.
std::vector<std::uint32_t> CompiledMap::monomial_degrees() const {
    std::vector<std::uint32_t> degree(num_monomials(), 1);
    degree[0] = 0;
    for (std::size_t m = 0; m < left_.size(); ++m) degree[1 + num_inputs_ + m] = degree[left_[m]] + degree[right_[m]];
    return degree;
}

// The group terms from first to the end, reordered from the highest degree down (stably), as FLINT orders a row's
// (ORD_DEGREVLEX): in the step's maps the high degrees are the small terms (powers of p), which summed after the large
// ones each round to the large partial sum's ulps, all the same way where they share a sign: a bias, not round-off
// (the Nambu-type scene's delta moved its Casimir by 8e-18 a step, docs/math.md 6).
void CompiledMap::order_from_highest_degree(std::size_t first, const std::vector<std::uint32_t>& degree) {
    const std::size_t L = group_monomial_.size() - first;
    std::vector<std::size_t> order(L);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return degree[group_monomial_[first + a]] > degree[group_monomial_[first + b]];
    });
    std::vector<std::uint32_t> monomial(L);
    std::vector<double> coeff(L * group_width);
    for (std::size_t q = 0; q < L; ++q) {
        monomial[q] = group_monomial_[first + order[q]];
        for (std::size_t i = 0; i < group_width; ++i)
            coeff[q * group_width + i] = group_coeff_[(first + order[q]) * group_width + i];
    }
    std::copy(monomial.begin(), monomial.end(), group_monomial_.begin() + std::ptrdiff_t(first));
    std::copy(coeff.begin(), coeff.end(), group_coeff_.begin() + std::ptrdiff_t(first * group_width));
}

template <class T>
void CompiledMap::eval_with(const T* in, T* out, T* mono) const {
    mono[0] = T(1);
    for (std::size_t v = 0; v < num_inputs_; ++v) mono[1 + v] = in[v];  // (a few: a loop, not a call to memmove)
    T* made = mono + 1 + num_inputs_;
    const std::size_t M = left_.size();
    for (std::size_t m = 0; m < M; ++m) made[m] = mono[left_[m]] * mono[right_[m]];
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
    if (row_vanishes_) [[unlikely]]  // (bind: a row's coefficient is 0 at these slow inputs)
        for (std::size_t o = 0; o < O; ++o)
            if (!std::isfinite(out[o])) out[o] = masked_row(o, mono);
    // the groups (series/compile_groups.ipp): in double one AVX2 vector or two pairs of SSE2 lanes (GCC does not
    // find those itself), the same bits
    if constexpr (std::is_same_v<T, double>) {
        if (fours_)
            eval_groups_avx2(tape(), mono, out);
        else
            eval_groups<GroupSums>(tape(), mono, out);
    } else {
        eval_groups<ScalarSums<T>>(tape(), mono, out);
    }
}

// Row o summed again as eval_with sums it (the same partial sums), a term whose coefficient vanishes at the slow
// inputs' values adding +0 (a sum begun at +0 is never -0: as if the term were absent) where its product would be
// 0 inf = NaN: the row of the map with those values written in, as the groups are (compile_groups.ipp). Only a
// non-finite row is summed again: a finite one read only finite monomials, which masking leaves as they are.
template <class T>
T CompiledMap::masked_row(std::size_t o, const T* mono) const {
    T s[4] = {0, 0, 0, 0};
    const std::uint32_t start = row_start_[o], end = row_start_[o + 1], quads = start + (end - start) / 4 * 4;
    for (std::uint32_t t = start; t < end; ++t)
        if (term_coeff_[t] != 0) s[t < quads ? (t - start) % 4 : 0] += T(term_coeff_[t]) * mono[term_monomial_[t]];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

// native code reads group_coeff_'s pairs as aligned SSE2 vectors (series/native.cpp, preamble)
static_assert(__STDCPP_DEFAULT_NEW_ALIGNMENT__ >= 16 && CompiledMap::group_width % 2 == 0);

void CompiledMap::eval(const double* in, double* out) const {
    if (slow_) bind(in + (num_inputs_ - slow_));
    const Code& code = native_.holder ? native_ : machine_;
    const auto at = [](const double* p) { return reinterpret_cast<std::uintptr_t>(p); };
    if (code.holder && !(at(in) < at(out + num_outputs()) && at(out) < at(in + num_inputs_))) {
        code.f(in, term_coeff_.data(), group_coeff_.data(), out);
        const std::size_t O = num_outputs();
        if (!slow_ || std::all_of(out, out + O, [](double v) { return std::isfinite(v); })) return;
    }
    eval_with(in, out, mono_.data());
}

void CompiledMap::eval_batch(const double* in, double* out, std::size_t m, std::vector<double>& scratch,
                             LaneCoefficients* kept) const {
    // Blocks of W lanes: the monomials of one block (W num_monomials() doubles) stay in cache whatever m is.
    constexpr std::size_t W = batch_lanes;
    const std::size_t M = num_monomials(), k = num_inputs_, O = num_outputs();
    // with slow inputs, each block's coefficients: kept's, or one cache in scratch that holds none at first
    const std::size_t cache = lane_cache_size(W), fresh = kept ? 0 : cache;
    if (scratch.size() < (M + k + O) * W + fresh) scratch.resize((M + k + O) * W + fresh);
    double* mono = scratch.data();
    double* coefficients = nullptr;
    if (slow_ && kept) coefficients = kept->get(*this, (m + W - 1) / W);
    if (slow_ && !kept) coefficients = mono + (M + k + O) * W, coefficients[0] = 0.0;
    const auto block_cache = [&](std::size_t j) { return kept ? coefficients + j / W * cache : coefficients; };
    std::size_t j = 0;
    for (; j + W <= m; j += W) eval_tape_lanes<W>(tape(), in + j, m, out + j, m, mono, block_cache(j));
    const std::size_t rest = m - j;
    if (rest == 0) return;
    double *tin = mono + M * W, *tout = tin + k * W;
    if (2 * rest < W &&
        slow_ == 0) {  // a few points left: one at a time costs less than a padded block (eval's own code)
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
    eval_tape_lanes<W>(tape(), tin, W, tout, W, mono, block_cache(j));
    for (std::size_t o = 0; o < O; ++o)
        for (std::size_t w = 0; w < rest; ++w) out[o * m + j + w] = tout[o * W + w];
}

void CompiledMap::eval(const long double* in, long double* out, std::vector<long double>& scratch) const {
    if (slow_) {
        std::vector<double> slow(in + (num_inputs_ - slow_), in + num_inputs_);
        bind(slow.data());
    }
    scratch.resize(num_monomials());
    eval_with(in, out, scratch.data());
}

}  // namespace pgi
