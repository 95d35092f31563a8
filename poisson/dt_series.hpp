#pragma once
// DtSeriesMap: x -> sum_j dt^j f_j(x), dt a run-time argument (as heyoka's runtime parameters): the
// polynomials f_j are compiled once, stacked into one CompiledMap (shared monomials), and combined with dt
// at run time by Horner. The step's S_dt (docs/math.md 5-6) and its predictor use it, so one exact phase
// and one compilation serve every dt. At the one dt the caller plans (the build's), the sum is also formed
// exactly and compiled as one map: there the stacked blocks would repeat every monomial the f_j share
// (Henon-Heiles k = 10: 1.55x the instructions of the step).
#include "series/compile.hpp"

#include <vector>

namespace pgi {

/// The caller's scratch of DtSeriesMap::eval_batch: the stacked blocks of m points and CompiledMap's, and the
/// coefficients of maps with slow inputs, kept across calls (one scratch serves the maps of one owner).
struct BatchScratch {
    std::vector<double> stacked, map;
    LaneCoefficients coefficients;
};

class DtSeriesMap {
public:
    DtSeriesMap() = default;
    /// terms[j - 1] = f_j, each a vector of the same number of polynomials (the width) in the ring
    /// variables inputs lists; the blocks that are identically zero are skipped (S_2 = S_4 = ... = 0).
    /// planned_dt: the dt at which eval uses the exact sum sum_j dt^j f_j compiled at once (0: none; none either where
    /// a coefficient of that sum is past the double range: eval overflows there as at any other dt). The last
    /// `slow` inputs (a scheme's parameters) are read through the coefficients (CompiledMap's two stages).
    static DtSeriesMap build(const std::vector<std::vector<Poly>>& terms, const std::vector<std::size_t>& inputs,
                             double planned_dt = 0, std::size_t slow = 0);

    std::size_t width() const { return width_; }
    /// Whether every f_j is zero (eval then writes zeros).
    bool empty() const { return powers_.empty(); }
    /// Multiply-adds of one eval, roughly: the compiled terms and monomials and the Horner combination.
    std::size_t cost() const { return map_.num_terms() + map_.num_monomials() + powers_.size() * width_; }
    /// The same at the planned dt.
    std::size_t planned_cost() const { return planned_dt_ ? planned_.num_terms() + planned_.num_monomials() : cost(); }

    /// The compiled maps eval runs, the planned one first (where there is one), then the stacked one: for native code.
    std::vector<CompiledMap*> compiled_maps();
    /// The map compiled at the planned dt, if there is one, else null.
    const CompiledMap* planned() const { return planned_dt_ != 0 ? &planned_ : nullptr; }
    /// The same if dt is the planned dt (what eval and eval_batch then run), else null.
    const CompiledMap* planned_at(double dt) const { return dt == planned_dt_ ? planned() : nullptr; }
    /// out[o] = sum_j dt^j f_j[o](in). Allocates nothing. Not thread-safe (scratch): each copy is one caller's.
    void eval(const double* in, double dt, double* out) const;
    /// m points at once in structure of arrays (CompiledMap::eval_batch's layout: in[v m + j], out[o m + j]),
    /// each point's outputs bit for bit eval()'s. scratch is resized when too small (reused, it allocates
    /// nothing). Not thread-safe (the cached powers of dt), as eval.
    void eval_batch(const double* in, double dt, double* out, std::size_t m, BatchScratch& scratch) const;

private:
    CompiledMap map_;
    CompiledMap planned_;  // sum_j planned_dt_^j f_j, exact before its rounding
    double planned_dt_ = 0;
    std::vector<std::size_t> powers_;  // the j of the non-zero blocks, ascending (block b of map_ is f_powers_[b])
    std::size_t width_ = 0;
    mutable std::vector<double> stacked_;
    mutable std::vector<double> factors_;  // dt^(powers_[b+1] - powers_[b]), then dt^(powers_[0]), for factors_dt_
    mutable double factors_dt_ = 0;
    void set_factors(double dt) const;
    void horner(const double* stacked, std::size_t stride, double* out) const;
};

}  // namespace pgi
