#pragma once
// CompiledMap: polynomials compiled once to a floating-point evaluator (heyoka's "build once, step fast").
#include "series/poly.hpp"
#include "series/value_ptr.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace pgi {

/// Whether this processor has AVX2: the wider group sums below, native code's and the batch step's AVX2 lanes run
/// only where it does.
bool processor_has_avx2();

/// How CompiledMap sums a group of four outputs: two pairs of SSE2 lanes, or one AVX2 vector of four (one multiply,
/// mask and add a term instead of two of each). Each lane does its own operations either way: the same bits.
enum class GroupVectors {
    automatic,  ///< AVX2 where the processor has it and that saves a tenth of the map's operations or more
                ///< (CompiledMap::fours_pay), else pairs: maps that are nearly all rows ran 2-5% slower on AVX2
    sse2,
    avx2,
};

class CompiledMap;

/// The lanes' coefficients of maps with parameters (CompiledMap::build's slow inputs), kept by their caller across
/// calls, so that a map's coefficients are evaluated again only where a lane's parameter values changed. Entries are
/// keyed by the map's build (get): one cache serves the maps of one owner (a stepper's, while it lives).
class LaneCoefficients {
public:
    /// map's cache of `blocks` blocks of CompiledMap::batch_lanes lanes from the first block (below), made (holding no
    /// lane's values) if new. Keyed by the map's build, not its address: copies of a map share a cache, and a map
    /// built anew at the address of another gets its own.
    double* get(const CompiledMap& map, std::size_t blocks);
    /// The calls that follow evaluate blocks from b on: a caller that steps several blocks of lanes in turn through
    /// one scratch keeps each block's coefficients apart.
    void set_first_block(std::size_t b) { first_ = b; }

    /// The maps whose caches are kept (a stepper's maps with slow inputs are a handful); the oldest goes first.
    static constexpr std::size_t max_entries = 16;

private:
    std::size_t first_ = 0;
    struct Entry {
        std::uint64_t serial;  // the map's build: a map rebuilt where another was never reads the other's cache
        std::vector<double> cache;
    };
    std::vector<Entry> entries_;
};

/// Several polynomials evaluated together in double: every monomial is formed once, as the product of two
/// monomials formed before it (the inputs first), and shared by all outputs; coefficients are rounded once
/// (correctly) at build time. eval() runs no FLINT code and allocates nothing.
///
/// Two stages, for parameters: the last `slow` inputs of a map built with them are read through its coefficients
/// only. Each output is a polynomial in the other inputs whose coefficients are polynomials in the slow ones (a
/// second, smaller map); those are evaluated when the slow inputs' values change, not at every evaluation, so a map
/// in (x, w) costs per evaluation about what the same map with w's values written in costs. Its results agree with
/// that map's to round-off, not bit for bit (the coefficients are sums in double, not rounded once).
class CompiledMap {
    friend class LaneCoefficients;

public:
    CompiledMap() = default;
    /// outputs are polynomials of one ring reading only the ring variables listed in inputs (which
    /// fixes the order of eval's input array). Throws std::invalid_argument naming a variable that
    /// an output reads but inputs does not list.
    static CompiledMap build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs);
    /// The same, the last `slow` of inputs read through the coefficients (two stages, above); slow <= inputs.size().
    static CompiledMap build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs,
                             std::size_t slow);

    std::size_t num_inputs() const { return num_inputs_; }
    /// The inputs read through the coefficients (the last ones), 0 for a map built without.
    std::size_t num_slow_inputs() const { return slow_; }
    /// The doubles a lane kernel's coefficient cache holds per block of `lanes` points (0 without slow inputs): the
    /// slow inputs' values it holds coefficients for, the coefficients, and the coefficient map's monomials.
    std::size_t lane_cache_size(std::size_t lanes) const;
    std::size_t num_outputs() const { return row_start_.empty() ? 0 : row_start_.size() - 1; }
    /// The monomials formed: the constant, the inputs, and the products.
    std::size_t num_monomials() const { return 1 + num_inputs_ + left_.size(); }
    /// The multiply-adds of one evaluation: the terms of the outputs evaluated one by one, and one per monomial
    /// of each group of outputs evaluated together (four at a time).
    std::size_t num_terms() const { return term_coeff_.size() + group_monomial_.size(); }

    /// out[o] = outputs[o](in). in has num_inputs() values, out num_outputs(); where they overlap the interpreter runs
    /// (attached code reads the inputs while it writes the outputs). Not thread-safe (scratch; with slow inputs, the
    /// bound coefficients), unless native or machine code without slow inputs.
    void eval(const double* in, double* out) const;

    /// The operations summing groups four lanes at once saves over pairs: one per group term whose coefficients are
    /// not all zero in either pair. fours_pay(): at least a tenth of num_terms() + num_monomials().
    std::size_t saved_by_fours() const;
    bool fours_pay() const { return fours_pay(saved_by_fours(), num_terms() + num_monomials()); }
    /// The rule, for maps taken together (native code builds one library for several).
    static bool fours_pay(std::size_t saved, std::size_t operations) { return 10 * saved >= operations; }
    /// eval() sums groups as v says from now on (build() chose automatic). Throws std::invalid_argument for avx2 on a
    /// processor without it.
    void set_group_vectors(GroupVectors v);
    bool groups_in_fours() const { return fours_; }

    /// What eval runs once native code is attached (series/native.hpp): the same outputs, bit for bit. The code holds
    /// the map's structure (its monomials, terms, groups, which of their coefficients are zero or equal) and reads the
    /// coefficients at run time, the rows' from term_coeff and the groups' from group_coeff (Tape), so one function
    /// serves every map of the same structure: the same polynomials at another dt or with other parameter values.
    /// With slow inputs the structure is the slots' (a coefficient zero or equal at every value of the slow inputs),
    /// eval binds the coefficients first, and an output that is not finite is evaluated again by the interpreter,
    /// which masks a coefficient that is zero at these values (an infinite monomial times it adds nothing).
    using NativeEval = void (*)(const double* in, const double* term_coeff, const double* group_coeff, double* out);
    /// eval() runs f from now on, library keeping its code loaded (shared by the copies of this map).
    void attach_native(std::shared_ptr<const void> library, NativeEval f) { native_ = {std::move(library), f}; }
    bool native() const { return native_.holder != nullptr; }
    /// What eval runs where no native code is attached: machine code written in memory for this map's structure and
    /// coefficients' zeros (series/machine_code.hpp), the same signature and bits; code keeps it alive (shared by the
    /// copies of this map).
    void attach_machine_code(std::shared_ptr<const void> code, NativeEval f) { machine_ = {std::move(code), f}; }
    bool machine_code() const { return machine_.holder != nullptr; }
    /// m points at once, structure of arrays: in[v m + j] is input v of point j, out[o m + j] is output o
    /// of point j. Every point's outputs are bit for bit eval()'s on it (the same operations in the same
    /// order, lane by lane; the loops over the points are the inner ones, which the compiler vectorises).
    /// The points are taken batch_lanes at a time (the last block padded), so scratch holds
    /// (num_monomials() + num_inputs() + num_outputs()) batch_lanes doubles whatever m is; it is resized when
    /// too small: reused, it allocates nothing. Unlike eval(), thread-safe (all scratch is the caller's).
    /// With slow inputs, each point has its own: kept (when given) holds the blocks' coefficients across calls,
    /// otherwise they are evaluated anew at each call, in one more block's cache that scratch then also holds
    /// (lane_cache_size(batch_lanes) doubles).
    void eval_batch(const double* in, double* out, std::size_t m, std::vector<double>& scratch,
                    LaneCoefficients* kept = nullptr) const;
    static constexpr std::size_t batch_lanes = 8;

    /// A grouped output's terms for the lanes (split_sums): from start, quads going into partial sums 0..3, then
    /// tail[a] terms into sum a; start is UINT32_MAX for an output evaluated from its row.
    struct LaneRow {
        std::uint32_t start, quads, tail[4];
    };
    /// The evaluator's arrays, read-only, for the lane kernel (series/compile_lanes.ipp) that each instruction set's
    /// file compiles for itself (the batch step's AVX2 file, poisson/lane_step_avx2.cpp, too).
    struct Tape {
        std::size_t inputs, products, outputs;
        const std::uint32_t *left, *right, *row_start, *term_monomial;
        const double* term_coeff;
        const LaneRow* lane_row;
        const std::uint32_t* lane_monomial;
        const double* lane_coeff;
        /// The groups as eval() reads them (series/native writes them the same way): group g's outputs (no_output
        /// where fewer than group_width), its terms group_start[g] .. group_start[g + 1] - 1, term t reading
        /// monomial group_monomial[t] times group_coeff[t group_width + i] for its output i (0: padding).
        std::size_t groups;
        const std::array<std::uint32_t, 4>* group_output;
        const std::uint32_t *group_start, *group_monomial;
        const double* group_coeff;
        /// With slow inputs (the last `slow`): the lane kernel reads term t's coefficient, lane by lane, as
        /// coefficient term_slot[t] (lane_slot for the lane rows) of `coefficients` at the lane's slow inputs.
        std::size_t slow;
        const CompiledMap* coefficients;
        const std::uint32_t *term_slot, *lane_slot;
        /// With slow inputs: the slot of group_coeff[t group_width + i] (no_output: zero at any slow inputs' values).
        const std::uint32_t* group_slot;
    };
    Tape tape() const {
        return {num_inputs_,
                left_.size(),
                num_outputs(),
                left_.data(),
                right_.data(),
                row_start_.data(),
                term_monomial_.data(),
                term_coeff_.data(),
                lane_row_.data(),
                lane_monomial_.data(),
                lane_coeff_.data(),
                group_output_.size(),
                group_output_.data(),
                group_start_.data(),
                group_monomial_.data(),
                group_coeff_.data(),
                slow_,
                coefficients_.operator->(),
                term_slot_.data(),
                lane_slot_.data(),
                group_slot_.data()};
    }
    static constexpr std::size_t group_width = 4;
    static constexpr std::uint32_t no_output = UINT32_MAX;
    /// The same polynomials (with the same double coefficients) in long double, for reference
    /// solutions of the problem the double evaluator defines; scratch is resized as needed.
    void eval(const long double* in, long double* out, std::vector<long double>& scratch) const;

private:
    std::size_t num_inputs_ = 0;
    // two stages: the coefficient map (slow inputs -> one value per slot), the slot of each coefficient below
    // (no_output for a group's padding), and the slow inputs' values the coefficients hold (none at first)
    std::size_t slow_ = 0;
    std::uint64_t serial_ = 0;  // the build this map's terms come from (copies share it): LaneCoefficients' key
    ValuePtr<CompiledMap> coefficients_;
    std::vector<std::uint32_t> term_slot_, group_slot_, lane_slot_;
    mutable std::vector<double> bound_, slot_values_;
    mutable bool bound_any_ = false;
    mutable bool row_vanishes_ = false;        // a row's coefficient is 0 at the bound values (eval_with masks it then)
    std::vector<std::uint32_t> left_, right_;  // monomial 1 + k + m = monomial[left_[m]] * monomial[right_[m]]
    std::vector<std::uint32_t> row_start_, term_monomial_;
    mutable std::vector<double> term_coeff_;  // (mutable: a map with slow inputs binds its coefficients in eval)
    // groups of up to group_width outputs read together: group g's terms group_start_[g] .. group_start_[g + 1] - 1,
    // term t reading monomial group_monomial_[t] times group_coeff_[t group_width + i] for its output i
    std::vector<std::array<std::uint32_t, group_width>> group_output_;
    std::vector<std::uint32_t> group_start_, group_monomial_;
    mutable std::vector<double> group_coeff_;
    // the lanes' terms of a grouped output (LaneRow): eval_with's sums without the zeros
    std::vector<LaneRow> lane_row_;
    std::vector<std::uint32_t> lane_monomial_;
    mutable std::vector<double> lane_coeff_;
    mutable std::vector<double> mono_;
    bool fours_ = false;  // eval() sums the groups on AVX2 (series/compile_avx2.cpp)
    // attached code, native or machine, and what keeps it loaded (a moved-from map holds none: it runs no code)
    struct Code {
        std::shared_ptr<const void> holder;
        NativeEval f = nullptr;
    };
    Code native_, machine_;
    void group_outputs();
    std::vector<std::uint32_t> monomial_degrees() const;
    void order_from_highest_degree(std::size_t first, const std::vector<std::uint32_t>& degree);
    void split_sums();
    // term_monomial_ holding target numbers: made[target] its monomial, left and right the products
    void finish(const std::vector<std::uint32_t>& made, std::vector<std::uint32_t> left,
                std::vector<std::uint32_t> right);
    void take_slots();
    void bind(const double* slow) const;
    template <class T>
    void eval_with(const T* in, T* out, T* mono) const;
    template <class T>
    T masked_row(std::size_t o, const T* mono) const;
};

}  // namespace pgi
