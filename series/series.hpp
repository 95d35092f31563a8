#pragma once
// Series: a truncated series c_0 + c_1 e + ... + c_{N-1} e^{N-1} + O(e^N) with polynomial coefficients.
// The grading e is either an implicit series variable (the time step t) or the homogeneous degree in
// a set of ring variables (the momenta p, then c_m is homogeneous of degree m in p). Products are
// truncated Cauchy products in both readings. A Series carries its truncation N, as obake's do.
#include "series/poly.hpp"

#include <vector>

namespace pgi {

class Series {
public:
    /// The zero series O(e^N).
    Series(RingPtr r, std::size_t N);
    /// c + O(e^N) (c at degree 0).
    static Series constant(const Poly& c, std::size_t N);
    /// Splits f by its degree in the masked variables: c_m = homogeneous_part(f, mask, m), m < N.
    static Series graded(const Poly& f, const VarMask& mask, std::size_t N);

    std::size_t order() const { return c_.size(); }
    const RingPtr& ring() const { return ring_; }
    const Poly& operator[](std::size_t m) const { return c_.at(m); }
    Poly& operator[](std::size_t m) { return c_.at(m); }
    /// c_0 + ... + c_{N-1}: the polynomial itself when the grading is a degree in ring variables.
    Poly sum() const;
    /// The same series with its truncation lowered to N' <= N.
    Series truncated(std::size_t N) const;

    Series& operator+=(const Series& o);
    Series& operator-=(const Series& o);
    Series& operator*=(const Rational& c);

private:
    RingPtr ring_;
    std::vector<Poly> c_;
};

bool operator==(const Series& a, const Series& b);
Series operator+(const Series& a, const Series& b);
Series operator-(const Series& a, const Series& b);
Series operator*(const Rational& c, const Series& a);
/// The truncated product a*b + O(e^N). Requires a.order() == b.order() (std::invalid_argument otherwise).
Series mul_trunc(const Series& a, const Series& b);

}  // namespace pgi
