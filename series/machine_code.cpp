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

// The code of one map. System V: in = rdi, term_coeff = rsi, group_coeff = rdx, out = rcx; the monomials on the stack
// (a frame of their own, probed page by page), mono[k] at rsp + 8 k. Scratch vector registers only; no call.
class Writer : public Xbyak::CodeGenerator {
public:
    Writer(const Tape& tape, bool wide, std::size_t bytes)
        : Xbyak::CodeGenerator(bytes, Xbyak::DontSetProtectRWE), tape_(tape), wide_(wide) {
        prologue();
        for (std::size_t k = 0; k < tape.products; ++k) product(k);
        for (std::size_t o = 0; o < tape.outputs; ++o)
            if (tape.lane_row[o].start == UINT32_MAX) row(o);
        for (std::size_t g = 0; g < tape.groups; ++g) group(g);
        epilogue();
        masks();
    }

    // An upper bound of the code's bytes: every instruction below takes at most 10 (VEX, ModRM, SIB, disp32).
    static std::size_t bound(const Tape& tape) {
        std::size_t instructions = 32 + 2 * tape.inputs + 3 * tape.products + 7 * tape.outputs;
        instructions += 3 * tape.row_start[tape.outputs];
        instructions += 4 * 2 * (tape.groups ? tape.group_start[tape.groups] : 0) + 20 * tape.groups;
        return 10 * instructions + 32 * 16 + 4096;
    }

private:
    const Tape& tape_;
    const bool wide_;
    std::size_t frame_ = 0;
    std::map<std::array<std::uint64_t, 4>, Xbyak::Label> masks_;

    Xbyak::Address mono(std::uint32_t k) { return qword[rsp + std::uint32_t(8 * k)]; }

    void prologue() {
        frame_ = (8 * (1 + tape_.inputs + tape_.products) + 31) / 32 * 32;
        // one page at a time, touching each, so that a large frame never steps over the stack's guard page
        for (std::size_t left = frame_; left > 0;) {
            const std::size_t page = left > 4096 ? 4096 : left;
            sub(rsp, std::uint32_t(page));
            mov(qword[rsp], 0);
            left -= page;
        }
        mov(rax, 0x3ff0000000000000ull);  // 1.0
        mov(qword[rsp], rax);
        for (std::size_t v = 0; v < tape_.inputs; ++v) {
            vmovsd(xmm0, qword[rdi + std::uint32_t(8 * v)]);
            vmovsd(mono(std::uint32_t(1 + v)), xmm0);
        }
    }

    // mono[1 + inputs + k] = mono[left] * mono[right]
    void product(std::size_t k) {
        const Xbyak::Xmm t(4 + int(k % 4));
        vmovsd(t, mono(tape_.left[k]));
        vmulsd(t, t, mono(tape_.right[k]));
        vmovsd(mono(std::uint32_t(1 + tape_.inputs + k)), t);
    }

    // An output from its row: four sums from +0 in xmm0..3, term i of L into sum i mod 4 (the last L mod 4 into 0).
    void row(std::size_t o) {
        for (int s = 0; s < 4; ++s) vxorpd(Xbyak::Xmm(s), Xbyak::Xmm(s), Xbyak::Xmm(s));
        const std::uint32_t start = tape_.row_start[o], L = tape_.row_start[o + 1] - start, rounds = L / 4 * 4;
        for (std::uint32_t i = 0; i < L; ++i) {
            const Xbyak::Xmm t(4 + int(i % 4)), s(i < rounds ? int(i % 4) : 0);
            vmovsd(t, qword[rsi + std::uint32_t(8 * (start + i))]);
            vmulsd(t, t, mono(tape_.term_monomial[start + i]));
            vaddsd(s, s, t);
        }
        pair_sums(0);
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
        for (int s = 0; s < 8; ++s) vxorpd(Xbyak::Ymm(s), Xbyak::Ymm(s), Xbyak::Ymm(s));
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
                if (!broadcast) broadcast_monomial(tape_.group_monomial[t]), broadcast = true;
                const Xbyak::Address coeff = ptr[rdx + std::uint32_t(8 * (G * t + first))];
                const int s = sum + (first ? 4 : 0);
                if (wide_) {
                    vmulpd(ymm8, ymm12, coeff);
                    if (masked) vandpd(ymm8, ymm8, ptr[rip + mask_label(mask)]);
                    vaddpd(Xbyak::Ymm(s), Xbyak::Ymm(s), ymm8);
                } else {
                    vmulpd(xmm8, xmm12, coeff);
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
        if (wide_)
            vbroadcastsd(ymm12, mono(k));
        else
            vmovddup(xmm12, mono(k));
    }

    Xbyak::Label& mask_label(const std::array<std::uint64_t, 4>& mask) { return masks_[mask]; }

    void epilogue() {
        add(rsp, std::uint32_t(frame_));
        vzeroupper();
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
    for (CompiledMap* m : maps) written += !m->native() && attach_machine_code(*m);
    return written;
}

}  // namespace pgi
