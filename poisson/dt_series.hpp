#pragma once
// DtSeriesMap: x -> sum_j dt^j f_j(x), dt a run-time argument (as heyoka's runtime parameters): the
// polynomials f_j are compiled once, stacked into one CompiledMap (shared monomials), and combined with dt
// at run time by Horner. The step's S_dt (docs/math.md 5-6) and its predictor use it, so one exact phase
// and one compilation serve every dt.
#include "series/compile.hpp"

#include <vector>

namespace pgi {

class DtSeriesMap {
public:
    DtSeriesMap() = default;
    /// terms[j - 1] = f_j, each a vector of the same number of polynomials (the width) in the ring
    /// variables inputs lists; the blocks that are identically zero are skipped (S_2 = S_4 = ... = 0).
    static DtSeriesMap build(const std::vector<std::vector<Poly>>& terms, const std::vector<std::size_t>& inputs);

    std::size_t width() const { return width_; }
    /// Whether every f_j is zero (eval then writes zeros).
    bool empty() const { return powers_.empty(); }
    /// Multiply-adds of one eval, roughly: the compiled terms and monomials and the Horner combination.
    std::size_t cost() const { return map_.num_terms() + map_.num_monomials() + powers_.size() * width_; }

    /// out[o] = sum_j dt^j f_j[o](in). Allocates nothing. Not thread-safe (scratch): each copy is one caller's.
    void eval(const double* in, double dt, double* out) const;

private:
    CompiledMap map_;
    std::vector<std::size_t> powers_;   // the j of the non-zero blocks, ascending (block b of map_ is f_powers_[b])
    std::size_t width_ = 0;
    mutable std::vector<double> stacked_;
};

}  // namespace pgi
