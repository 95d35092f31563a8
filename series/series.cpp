#include "series/series.hpp"

#include <stdexcept>

namespace pgi {

namespace {

void require_same_order(const Series& a, const Series& b, const char* where) {
    if (a.order() != b.order())
        throw std::invalid_argument(std::string(where) + ": truncation orders differ (" + std::to_string(a.order()) +
                                    " and " + std::to_string(b.order()) + ")");
}

}  // namespace

Series::Series(RingPtr r, std::size_t N) : ring_(std::move(r)), c_(N, Poly(ring_)) {}

Series Series::constant(const Poly& c, std::size_t N) {
    Series s(c.ring(), N);
    if (N > 0) s.c_[0] = c;
    return s;
}

Series Series::graded(const Poly& f, const VarMask& mask, std::size_t N) {
    Series s(f.ring(), N);
    for (std::size_t m = 0; m < N; ++m) s.c_[m] = homogeneous_part(f, mask, m);
    return s;
}

Poly Series::sum() const {
    Poly r(ring_);
    for (const auto& c : c_) r += c;
    return r;
}

Series Series::truncated(std::size_t N) const {
    if (N > order()) throw std::invalid_argument("pgi::Series::truncated: cannot raise the truncation order");
    Series s(ring_, N);
    for (std::size_t m = 0; m < N; ++m) s.c_[m] = c_[m];
    return s;
}

Series& Series::operator+=(const Series& o) {
    require_same_order(*this, o, "pgi::Series add");
    for (std::size_t m = 0; m < c_.size(); ++m) c_[m] += o.c_[m];
    return *this;
}
Series& Series::operator-=(const Series& o) {
    require_same_order(*this, o, "pgi::Series sub");
    for (std::size_t m = 0; m < c_.size(); ++m) c_[m] -= o.c_[m];
    return *this;
}
Series& Series::operator*=(const Rational& c) {
    for (auto& p : c_) p *= c;
    return *this;
}

bool operator==(const Series& a, const Series& b) {
    if (a.order() != b.order()) return false;
    for (std::size_t m = 0; m < a.order(); ++m)
        if (!(a[m] == b[m])) return false;
    return true;
}
Series operator+(const Series& a, const Series& b) {
    Series r(a);
    r += b;
    return r;
}
Series operator-(const Series& a, const Series& b) {
    Series r(a);
    r -= b;
    return r;
}
Series operator*(const Rational& c, const Series& a) {
    Series r(a);
    r *= c;
    return r;
}

Series mul_trunc(const Series& a, const Series& b) {
    require_same_order(a, b, "pgi::mul_trunc");
    Series r(a.ring(), a.order());
    for (std::size_t i = 0; i < a.order(); ++i) {
        if (a[i].is_zero()) continue;
        for (std::size_t j = 0; i + j < a.order(); ++j)
            if (!b[j].is_zero()) r[i + j] += a[i] * b[j];
    }
    return r;
}

}  // namespace pgi
