#include "series/compile.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace pgi {

namespace {

using Exponent = std::vector<unsigned long>;  // one entry per input

// Total degree first, so a monomial's parent (one degree less) is always numbered before it.
struct DegreeOrder {
    bool operator()(const Exponent& a, const Exponent& b) const {
        unsigned long da = 0, db = 0;
        for (auto e : a) da += e;
        for (auto e : b) db += e;
        return da != db ? da < db : a < b;
    }
};

}  // namespace

CompiledMap CompiledMap::build(const std::vector<Poly>& outputs, const std::vector<std::size_t>& inputs) {
    CompiledMap c;
    c.num_inputs_ = inputs.size();
    if (outputs.empty()) return c;
    const RingPtr& ring = outputs.front().ring();
    std::vector<long> slot(ring->size(), -1);  // ring variable -> input position
    for (std::size_t i = 0; i < inputs.size(); ++i) slot.at(inputs[i]) = static_cast<long>(i);

    // Every monomial the outputs use, closed under "remove one unit of the first variable".
    std::map<Exponent, std::uint32_t, DegreeOrder> index;
    std::vector<std::vector<std::pair<Exponent, double>>> rows(outputs.size());
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        const Poly& f = outputs[o];
        for (std::size_t t = 0; t < f.length(); ++t) {
            auto e = f.term_exponents(t);
            Exponent x(inputs.size(), 0);
            for (std::size_t v = 0; v < e.size(); ++v) {
                if (e[v] == 0) continue;
                if (slot[v] < 0)
                    throw std::invalid_argument("pgi::CompiledMap: output " + std::to_string(o) + " reads '" + ring->names()[v] +
                                                "', which is not an input");
                x[static_cast<std::size_t>(slot[v])] = e[v];
            }
            const double coeff = f.term_coeff(t).to_double();
            // NOTE: never let a rational become an infinite double silently
            if (!std::isfinite(coeff))
                throw std::invalid_argument("a coefficient of " + std::to_string(fmpz_sizeinbase(fmpq_numref(f.term_coeff(t).get()), 10)) +
                                            " digits in output " + std::to_string(o) + " is beyond the double range");
            rows[o].emplace_back(x, coeff);
            for (Exponent y = x; index.emplace(y, 0).second;) {
                auto v = std::find_if(y.begin(), y.end(), [](unsigned long k) { return k > 0; });
                if (v == y.end()) break;
                --*v;
            }
        }
    }
    index.emplace(Exponent(inputs.size(), 0), 0);
    std::uint32_t next = 0;
    for (auto& [e, id] : index) {
        id = next++;
        if (id == 0) continue;  // the constant monomial
        Exponent parent = e;
        auto v = std::find_if(parent.begin(), parent.end(), [](unsigned long k) { return k > 0; });
        --*v;
        c.parent_.push_back(index.at(parent));
        c.var_.push_back(static_cast<std::uint32_t>(v - parent.begin()));
    }
    c.row_start_.push_back(0);
    for (const auto& row : rows) {
        for (const auto& [e, coeff] : row) {
            c.term_monomial_.push_back(index.at(e));
            c.term_coeff_.push_back(coeff);
        }
        c.row_start_.push_back(static_cast<std::uint32_t>(c.term_coeff_.size()));
    }
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

void CompiledMap::eval(const long double* in, long double* out, std::vector<long double>& scratch) const {
    scratch.resize(num_monomials());
    eval_with(in, out, scratch.data());
}

}  // namespace pgi
