#include "poisson/dt_series.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pgi {

namespace {

bool coefficients_are_doubles(const Poly& f) {
    for (std::size_t t = 0; t < f.length(); ++t)
        if (!std::isfinite(f.term_coeff(t).to_double())) return false;
    return true;
}

}  // namespace

DtSeriesMap DtSeriesMap::build(const std::vector<std::vector<Poly>>& terms, const std::vector<std::size_t>& inputs,
                               double planned_dt, std::size_t slow) {
    DtSeriesMap m;
    m.width_ = terms.empty() ? 0 : terms.front().size();
    std::vector<Poly> stacked;
    for (std::size_t j = 1; j <= terms.size(); ++j) {
        const auto& f = terms[j - 1];
        if (f.size() != m.width_)
            throw std::invalid_argument("DtSeriesMap: every term must have the same number of polynomials");
        if (std::all_of(f.begin(), f.end(), [](const Poly& p) { return p.is_zero(); })) continue;
        m.powers_.push_back(j);
        stacked.insert(stacked.end(), f.begin(), f.end());
    }
    if (!stacked.empty()) m.map_ = CompiledMap::build(stacked, inputs, slow);
    if (planned_dt != 0 && !stacked.empty()) {
        const Rational dt = Rational::from_double(planned_dt);  // exactly the double
        std::vector<Poly> sums;
        for (std::size_t o = 0; o < m.width_; ++o) {
            std::vector<Poly> c;
            for (const auto& f : terms) c.push_back(f[o]);
            sums.push_back(sum_powers(c, dt, 1));
        }
        // a dt whose powers put a coefficient past the double range is not planned: Horner then overflows at run
        // time, and the step fails there with its step and time, instead of the build naming a coefficient
        if (std::all_of(sums.begin(), sums.end(), coefficients_are_doubles)) {
            m.planned_ = CompiledMap::build(sums, inputs, slow);
            m.planned_dt_ = planned_dt;
        }
    }
    m.stacked_.assign(stacked.size(), 0.0);
    m.factors_.assign(m.powers_.size(), 0.0);
    if (!m.powers_.empty()) m.set_factors(1.0);
    return m;
}

void DtSeriesMap::set_factors(double dt) const {
    const auto power = [dt](std::size_t e) {
        double f = 1;
        for (std::size_t i = 0; i < e; ++i) f *= dt;
        return f;
    };
    for (std::size_t b = 0; b + 1 < powers_.size(); ++b) factors_[b] = power(powers_[b + 1] - powers_[b]);
    factors_.back() = power(powers_.front());
    factors_dt_ = dt;
}

// Horner from the highest power down: acc = f_top; acc = acc dt^(j - j') + f_j' for the next lower j'; and
// a last factor dt^(lowest j). The factors are computed once per dt. stacked holds block b's output o of
// point j at stacked[(b w + o) stride + j] and out[o stride + j] (stride 1 for one point: eval).
void DtSeriesMap::horner(const double* stacked, std::size_t stride, double* out) const {
    const std::size_t w = width_ * stride;
    std::size_t b = powers_.size() - 1;
    const double* top = stacked + b * w;
    std::copy(top, top + w, out);
    while (b > 0) {
        const double f = factors_[b - 1];
        --b;
        const double* block = stacked + b * w;
        for (std::size_t o = 0; o < w; ++o) out[o] = out[o] * f + block[o];
    }
    const double f = factors_.back();
    for (std::size_t o = 0; o < w; ++o) out[o] *= f;
}

std::vector<CompiledMap*> DtSeriesMap::compiled_maps() {
    if (powers_.empty()) return {};
    if (planned_dt_ != 0) return {&planned_, &map_};
    return {&map_};
}

void DtSeriesMap::eval(const double* in, double dt, double* out) const {
    if (powers_.empty()) {
        std::fill(out, out + width_, 0.0);
        return;
    }
    if (planned_dt_ != 0 && dt == planned_dt_) {
        planned_.eval(in, out);
        return;
    }
    map_.eval(in, stacked_.data());
    if (!(dt == factors_dt_)) set_factors(dt);
    horner(stacked_.data(), 1, out);
}

// The same operations on each point as eval's (CompiledMap::eval_batch gives eval's bits, Horner is
// elementwise), so each point's outputs are eval's.
void DtSeriesMap::eval_batch(const double* in, double dt, double* out, std::size_t m, BatchScratch& scratch) const {
    if (powers_.empty()) {
        std::fill(out, out + width_ * m, 0.0);
        return;
    }
    if (planned_dt_ != 0 && dt == planned_dt_) {
        planned_.eval_batch(in, out, m, scratch.map, &scratch.coefficients);
        return;
    }
    if (scratch.stacked.size() < map_.num_outputs() * m) scratch.stacked.resize(map_.num_outputs() * m);
    map_.eval_batch(in, scratch.stacked.data(), m, scratch.map, &scratch.coefficients);
    if (!(dt == factors_dt_)) set_factors(dt);
    horner(scratch.stacked.data(), m, out);
}

}  // namespace pgi
