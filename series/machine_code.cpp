#include "series/machine_code.hpp"

#if defined(__x86_64__)
#define XBYAK_NO_OP_NAMES
#include <xbyak/xbyak.h>
#endif

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <new>
#include <stdexcept>
#include <vector>

namespace pgi {

#if defined(__x86_64__)

bool machine_code_supported() {
    return __builtin_cpu_supports("avx");
}

namespace {

using Tape = CompiledMap::Tape;
constexpr std::size_t G = CompiledMap::group_width;

// Whether group coefficient i is zero whatever the slow inputs' values (a zero of this map's coefficients otherwise:
// the code is written for this map and its copies, whose coefficients never change), so that its lane is masked.
bool group_zero(const Tape& tape, std::size_t i) {
    return tape.slow ? tape.group_slot[i] == CompiledMap::no_output : tape.group_coeff[i] == 0;
}

// Whether group g's term t has a lane whose coefficient is not zero (else it adds nothing and is left out).
bool term_adds(const Tape& tape, std::uint32_t t) {
    for (std::size_t lane = 0; lane < G; ++lane)
        if (!group_zero(tape, G * t + lane)) return true;
    return false;
}

// The monomials the code reads, in the order it reads them: each product's two factors, each row's terms, each group
// term's monomial (once, for all its lanes).
std::vector<std::uint32_t> reads_of(const Tape& tape) {
    std::vector<std::uint32_t> reads;
    for (std::size_t k = 0; k < tape.products; ++k) reads.push_back(tape.left[k]), reads.push_back(tape.right[k]);
    for (std::size_t o = 0; o < tape.outputs; ++o)
        if (tape.lane_row[o].start == UINT32_MAX)
            for (std::uint32_t t = tape.row_start[o]; t < tape.row_start[o + 1]; ++t)
                reads.push_back(tape.term_monomial[t]);
    for (std::size_t g = 0; g < tape.groups; ++g)
        for (std::uint32_t t = tape.group_start[g]; t < tape.group_start[g + 1]; ++t)
            if (term_adds(tape, t)) reads.push_back(tape.group_monomial[t]);
    return reads;
}

// Which monomials are in which vector registers, the rest read from memory: a value read again is kept in a register,
// and where none is free the one read again last (or never) gives way (Belady's rule: the reads are known in advance).
// Every monomial is also in memory, so a register is dropped without a store.
class RegisterCache {
public:
    RegisterCache(std::vector<std::uint32_t> reads, std::size_t monomials)
        : reads_(std::move(reads)), where_(monomials, none), next_(reads_.size()), next_use_(monomials, never) {
        held_.fill(UINT32_MAX);
        std::vector<std::size_t> seen(monomials, never);
        for (std::size_t i = reads_.size(); i-- > 0;) next_[i] = seen[reads_[i]], seen[reads_[i]] = i;
        first_ = std::move(seen);
    }
    static constexpr int none = -1;
    static constexpr std::size_t never = SIZE_MAX;

    // The registers values may be kept in from now on (the others are dropped: the code uses them otherwise).
    void use_registers(int first, int last) {
        for (int r = 0; r < 16; ++r)
            if ((r < first || r > last) && held_[std::size_t(r)] != UINT32_MAX) drop(r);
        first_reg_ = first, last_reg_ = last;
    }
    // The next read, of monomial m: the register holding it, or none (then it is in memory). A value read again is
    // loaded into a register first where one can be had (load(r) emits the load). pinned: not to be evicted.
    template <class Load>
    int read(std::uint32_t m, Load&& load, int pinned = none) {
        const std::size_t i = position_++;
        if (i >= reads_.size() || reads_[i] != m)
            throw std::logic_error("machine code: reads out of their planned order");
        const std::size_t again = next_[i];
        next_use_[m] = again;
        int r = where_[m];
        if (r == none && again != never && (r = take(again, pinned)) != none) {
            hold(r, m);
            load(r);
        }
        return r;
    }
    // A register for monomial m, just computed (its first read is later), or none if it is not worth one.
    int define(std::uint32_t m, int pinned_a, int pinned_b) {
        const std::size_t again = first_[m];
        next_use_[m] = again;
        if (again == never) return none;
        const int r = take(again, pinned_a, pinned_b);
        if (r != none) hold(r, m);
        return r;
    }

private:
    std::vector<std::uint32_t> reads_;
    std::vector<int> where_;
    std::vector<std::size_t> next_, first_, next_use_;  // per read, per monomial (its first read), per monomial
    std::array<std::uint32_t, 16> held_;
    std::size_t position_ = 0;
    int first_reg_ = 0, last_reg_ = -1;

    std::size_t next_use(int r) const { return next_use_[held_[std::size_t(r)]]; }
    void hold(int r, std::uint32_t m) { held_[std::size_t(r)] = m, where_[m] = r; }
    void drop(int r) {
        where_[held_[std::size_t(r)]] = none;
        held_[std::size_t(r)] = UINT32_MAX;
    }
    // A free register, or the one whose value is read again last if that is after `again`.
    int take(std::size_t again, int pinned_a = none, int pinned_b = none) {
        int victim = none;
        std::size_t latest = again;
        for (int r = first_reg_; r <= last_reg_; ++r) {
            if (r == pinned_a || r == pinned_b) continue;
            if (held_[std::size_t(r)] == UINT32_MAX) return r;
            const std::size_t n = next_use(r);
            if (n > latest) victim = r, latest = n;
        }
        if (victim != none) drop(victim);
        return victim;
    }
};

// The code of one map. System V: in = rdi, term_coeff = rsi, group_coeff = rdx, out = rcx; the inputs read where they
// are, 1 and the products on the stack (a frame of their own, probed page by page), those read again kept in vector
// registers as RegisterCache decides. Scratch vector registers only; no call.
class Writer : public Xbyak::CodeGenerator {
public:
    Writer(const Tape& tape, bool wide, std::size_t bytes)
        : Xbyak::CodeGenerator(bytes, Xbyak::DontSetProtectRWE), tape_(tape), wide_(wide),
          cache_(reads_of(tape), 1 + tape.inputs + tape.products) {
        prologue();
        cache_.use_registers(0, 14);  // (xmm15: a product read no more)
        for (std::size_t k = 0; k < tape.products; ++k) product(k);
        cache_.use_registers(6, 15);  // (xmm0..3: a row's sums, xmm4..5: its terms)
        for (std::size_t o = 0; o < tape.outputs; ++o)
            if (tape.lane_row[o].start == UINT32_MAX) row(o);
        cache_.use_registers(10, 15);  // (xmm0..7: a group's sums, xmm8: a term, xmm9: its monomial)
        for (std::size_t g = 0; g < tape.groups; ++g) group(g);
        epilogue();
        masks();
        cache_ = RegisterCache({}, 0);  // (the code is all a map keeps: the planning goes)
        masks_.clear();
    }

    // An upper bound of the code's bytes: every instruction below takes at most 10 (VEX, ModRM, SIB, disp32).
    static std::size_t bound(const Tape& tape) {
        std::size_t instructions = 40 + 2 * tape.inputs + 5 * tape.products + 8 * tape.outputs;
        instructions += 4 * tape.row_start[tape.outputs];
        instructions += 10 * (tape.groups ? tape.group_start[tape.groups] : 0) + 25 * tape.groups;
        return 10 * instructions + 64 * 16 + 4096;
    }

private:
    const Tape tape_;  // (the map's arrays, read while the code is written)
    const bool wide_;
    RegisterCache cache_;
    std::size_t frame_ = 0;
    std::map<std::array<std::uint64_t, 4>, Xbyak::Label> masks_;

    // Where monomial k is: 1 at rsp, an input where the caller has it, a product at rsp + 8 (k - inputs).
    Xbyak::Address mono(std::uint32_t k) {
        if (k >= 1 && k <= tape_.inputs) return qword[rdi + std::uint32_t(8 * (k - 1))];
        return qword[rsp + std::uint32_t(8 * (k == 0 ? 0 : k - tape_.inputs))];
    }
    // The next read, of monomial k: its register, or none (then mono(k) is read).
    int read(std::uint32_t k, int pinned = RegisterCache::none) {
        return cache_.read(
            k, [&](int r) { vmovsd(Xbyak::Xmm(r), mono(k)); }, pinned);
    }

    void prologue() {
        frame_ = (8 * (1 + tape_.products) + 31) / 32 * 32;
        // a page at a time, touching each, so that a large frame never steps over the stack's guard page
        std::size_t left = frame_;
        for (; left > 4096; left -= 4096) sub(rsp, 4096), mov(qword[rsp], 0);
        sub(rsp, std::uint32_t(left));
        mov(rax, 0x3ff0000000000000ull);  // 1.0
        mov(qword[rsp], rax);
    }

    // mono[1 + inputs + k] = mono[left] * mono[right] (the product commutes: either factor may come from memory)
    void product(std::size_t k) {
        const std::uint32_t m = std::uint32_t(1 + tape_.inputs + k);
        const int a = read(tape_.left[k]), b = read(tape_.right[k], a);
        const int kept = cache_.define(m, a, b);
        const Xbyak::Xmm d(kept == RegisterCache::none ? 15 : kept);
        if (a != RegisterCache::none && b != RegisterCache::none)
            vmulsd(d, Xbyak::Xmm(a), Xbyak::Xmm(b));
        else if (a != RegisterCache::none)
            vmulsd(d, Xbyak::Xmm(a), mono(tape_.right[k]));
        else if (b != RegisterCache::none)
            vmulsd(d, Xbyak::Xmm(b), mono(tape_.left[k]));
        else
            vmovsd(d, mono(tape_.left[k])), vmulsd(d, d, mono(tape_.right[k]));
        vmovsd(mono(m), d);
    }

    // An output from its row: four sums from +0 in xmm0..3, term i of L into sum i mod 4 (the last L mod 4 into 0).
    // Under four terms only sum 0 has any: the others are +0, and adding +0 to a sum begun at +0 (never -0) leaves it.
    void row(std::size_t o) {
        const std::uint32_t start = tape_.row_start[o], L = tape_.row_start[o + 1] - start, rounds = L / 4 * 4;
        for (int s = 0; s < (L < 4 ? 1 : 4); ++s) vxorpd(Xbyak::Xmm(s), Xbyak::Xmm(s), Xbyak::Xmm(s));
        for (std::uint32_t i = 0; i < L; ++i) {
            const Xbyak::Xmm t(4 + int(i % 2)), s(i < rounds ? int(i % 4) : 0);
            const Xbyak::Address c = qword[rsi + std::uint32_t(8 * (start + i))];
            const std::uint32_t m = tape_.term_monomial[start + i];
            if (const int r = read(m); r != RegisterCache::none)
                vmulsd(t, Xbyak::Xmm(r), c);
            else
                vmovsd(t, c), vmulsd(t, t, mono(m));
            vaddsd(s, s, t);
        }
        if (L >= 4) pair_sums(0);
        vmovsd(qword[rcx + std::uint32_t(8 * o)], xmm0);
    }
    // Register 0 = (0 + 1) + (2 + 3), from `first` (xmm or ymm as the registers were used).
    template <class R>
    void pair_sums_of(int first) {
        const R a(first), b(first + 1), c(first + 2), d(first + 3);
        vaddpd(a, a, b);
        vaddpd(c, c, d);
        vaddpd(a, a, c);
    }
    void pair_sums(int first) {
        const Xbyak::Xmm a(first), b(first + 1), c(first + 2), d(first + 3);
        vaddsd(a, a, b);
        vaddsd(c, c, d);
        vaddsd(a, a, c);
    }

    // A group of four outputs as eval_with's sums (native.cpp's group_statement, the same operations): wide, one
    // vector of four lanes (ymm0..3 the partial sums); else two pairs (lo: outputs 0, 1 in xmm0..3; hi: 2, 3 in
    // xmm4..7). Term p of the group's L goes into sum p mod 4 (the last L mod 4 into sum 0): its coefficients times
    // the monomial, masked to +0 in a lane whose coefficient is zero unless the lane has no output; a vector of zeros
    // adds +0 and is left out.
    void group(std::size_t g) {
        for (int s = 0; s < 8; ++s) vxorpd(Xbyak::Xmm(s), Xbyak::Xmm(s), Xbyak::Xmm(s));  // (VEX: the upper halves too)
        const std::uint32_t start = tape_.group_start[g], L = tape_.group_start[g + 1] - start, rounds = L / 4 * 4;
        const std::size_t width = wide_ ? 4 : 2;
        for (std::uint32_t p = 0; p < L; ++p) {
            const std::uint32_t t = start + p;
            const int sum = p < rounds ? int(p % 4) : 0;
            bool broadcast = false;
            for (std::size_t first = 0; first < G; first += width) {
                std::array<std::uint64_t, 4> mask{};
                bool any = false, masked = false;
                for (std::size_t lane = first; lane < first + width; ++lane) {
                    const bool zero = group_zero(tape_, G * t + lane),
                               keep = !zero || tape_.group_output[g][lane] == CompiledMap::no_output;
                    any = any || !zero;
                    masked = masked || !keep;
                    mask[lane - first] = keep ? ~std::uint64_t(0) : 0;
                }
                if (!any) continue;
                if (!broadcast) broadcast_monomial(tape_.group_monomial[t]), broadcast = true;  // (xmm9 / ymm9)
                const Xbyak::Address coeff = ptr[rdx + std::uint32_t(8 * (G * t + first))];
                const int s = sum + (first ? 4 : 0);
                if (wide_) {
                    vmulpd(ymm8, ymm9, coeff);
                    if (masked) vandpd(ymm8, ymm8, ptr[rip + mask_label(mask)]);
                    vaddpd(Xbyak::Ymm(s), Xbyak::Ymm(s), ymm8);
                } else {
                    vmulpd(xmm8, xmm9, coeff);
                    if (masked) vandpd(xmm8, xmm8, ptr[rip + mask_label(mask)]);
                    vaddpd(Xbyak::Xmm(s), Xbyak::Xmm(s), xmm8);
                }
            }
        }
        if (wide_) {
            pair_sums_of<Xbyak::Ymm>(0);
            vextractf128(xmm4, ymm0, 1);
        } else {
            pair_sums_of<Xbyak::Xmm>(0);
            pair_sums_of<Xbyak::Xmm>(4);
        }
        for (std::size_t i = 0; i < G; ++i) {
            const std::uint32_t o = tape_.group_output[g][i];
            if (o == CompiledMap::no_output) continue;
            const Xbyak::Address to = qword[rcx + std::uint32_t(8 * o)];
            const Xbyak::Xmm& from = i < 2 ? xmm0 : xmm4;
            if (i % 2 == 0)
                vmovlpd(to, from);
            else
                vmovhpd(to, from);
        }
    }

    void broadcast_monomial(std::uint32_t k) {
        const int r = read(k);
        if (r != RegisterCache::none && wide_)
            vbroadcastsd(ymm9, Xbyak::Xmm(r));  // (AVX2: groups in fours run only where it is)
        else if (r != RegisterCache::none)
            vmovddup(xmm9, Xbyak::Xmm(r));
        else if (wide_)
            vbroadcastsd(ymm9, mono(k));
        else
            vmovddup(xmm9, mono(k));
    }

    Xbyak::Label& mask_label(const std::array<std::uint64_t, 4>& mask) { return masks_[mask]; }

    void epilogue() {
        add(rsp, std::uint32_t(frame_));
        vzeroupper();  // (the caller's SSE code would otherwise wait on upper halves it does not know of)
        ret();
    }

    // The masks the groups read, after the code, each 32-byte aligned.
    void masks() {
        for (auto& [mask, label] : masks_) {
            align(32);
            L(label);
            for (const std::uint64_t m : mask) dq(m);
        }
    }
};

}  // namespace

bool attach_machine_code(CompiledMap& map) {
    if (map.machine_code()) return true;
    if (map.native()) return false;
    if (map.num_outputs() == 0 || map.num_terms() + map.num_monomials() > machine_code_max_size ||
        !machine_code_supported())
        return false;
    const Tape tape = map.tape();
    try {
        auto code = std::make_shared<Writer>(tape, map.groups_in_fours(), Writer::bound(tape));
        if (!code->setProtectModeRE(false)) return false;  // (the system refuses executable memory)
        const auto f = code->getCode<CompiledMap::NativeEval>();
        map.attach_machine_code(std::shared_ptr<const void>(code, code.get()), f);
        return true;
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const Xbyak::Error&) {
        return false;  // (no memory could be mapped, or the bound was short: the interpreter stays)
    }
}

#else

bool machine_code_supported() {
    return false;
}

bool attach_machine_code(CompiledMap& map) {
    return map.machine_code();
}

#endif

std::size_t attach_machine_code(const std::vector<CompiledMap*>& maps) {
    std::size_t written = 0;
    for (CompiledMap* m : maps) written += attach_machine_code(*m);
    return written;
}

std::size_t attach_machine_code(const std::vector<CompiledMap*>& maps, NativePolicy policy) {
    return policy == NativePolicy::never ? 0 : attach_machine_code(maps);
}

}  // namespace pgi
