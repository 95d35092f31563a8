#include "poisson/dt_series.hpp"

#include <algorithm>
#include <stdexcept>

namespace pgi {

DtSeriesMap DtSeriesMap::build(const std::vector<std::vector<Poly>>& terms, const std::vector<std::size_t>& inputs) {
    DtSeriesMap m;
    m.width_ = terms.empty() ? 0 : terms.front().size();
    std::vector<Poly> stacked;
    for (std::size_t j = 1; j <= terms.size(); ++j) {
        const auto& f = terms[j - 1];
        if (f.size() != m.width_) throw std::invalid_argument("DtSeriesMap: every term must have the same number of polynomials");
        if (std::all_of(f.begin(), f.end(), [](const Poly& p) { return p.is_zero(); })) continue;
        m.powers_.push_back(j);
        stacked.insert(stacked.end(), f.begin(), f.end());
    }
    if (!stacked.empty()) m.map_ = CompiledMap::build(stacked, inputs);
    m.stacked_.assign(stacked.size(), 0.0);
    return m;
}

// Horner from the highest power down: acc = f_top; acc = acc dt^(j - j') + f_j' for the next lower j'; and
// a last factor dt^(lowest j).
void DtSeriesMap::eval(const double* in, double dt, double* out) const {
    const std::size_t w = width_;
    if (powers_.empty()) {
        std::fill(out, out + w, 0.0);
        return;
    }
    map_.eval(in, stacked_.data());
    const auto power = [dt](std::size_t e) {
        double f = 1;
        for (std::size_t i = 0; i < e; ++i) f *= dt;
        return f;
    };
    std::size_t b = powers_.size() - 1;
    std::copy(stacked_.begin() + std::ptrdiff_t(b * w), stacked_.begin() + std::ptrdiff_t((b + 1) * w), out);
    while (b > 0) {
        const double f = power(powers_[b] - powers_[b - 1]);
        --b;
        const double* block = stacked_.data() + b * w;
        for (std::size_t o = 0; o < w; ++o) out[o] = out[o] * f + block[o];
    }
    const double f = power(powers_.front());
    for (std::size_t o = 0; o < w; ++o) out[o] *= f;
}

}  // namespace pgi
