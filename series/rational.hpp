#pragma once
// Rational: an exact number of Q as a value type over FLINT's fmpq_t.
#include <flint/fmpq.h>

#include <stdexcept>

#include <string>
#include <string_view>

namespace pgi {

class Rational {
public:
    Rational() { fmpq_init(q_); }
    Rational(long num, unsigned long den = 1);
    Rational(const Rational& o) : Rational() { fmpq_set(q_, o.q_); }
    Rational(Rational&& o) noexcept : Rational() { fmpq_swap(q_, o.q_); }
    Rational& operator=(Rational o) noexcept {
        fmpq_swap(q_, o.q_);
        return *this;
    }
    ~Rational() { fmpq_clear(q_); }

    /// Parses "a", "-a/b", or a decimal "1.25", "-3e-2" (exactly, no rounding through double).
    /// Throws std::invalid_argument naming the text when it is none of these or has a zero denominator.
    static Rational parse(std::string_view text);
    /// The exact value of a finite double. Throws std::invalid_argument on NaN or infinity.
    static Rational from_double(double v);

    const fmpq* get() const { return q_; }
    fmpq* get_mut() { return q_; }

    bool is_zero() const { return fmpq_is_zero(q_); }
    /// The double nearest to the value (correctly rounded, ties to even; +-inf past the range).
    double to_double() const;
    std::string to_string() const;

    friend bool operator==(const Rational& a, const Rational& b) { return fmpq_equal(a.q_, b.q_); }
    friend Rational operator+(const Rational& a, const Rational& b);
    friend Rational operator-(const Rational& a, const Rational& b);
    friend Rational operator*(const Rational& a, const Rational& b);
    friend Rational operator/(const Rational& a, const Rational& b);  // throws on b == 0
    friend Rational operator-(const Rational& a);

private:
    fmpq_t q_;
};

/// The Bernoulli number B_n of z/(e^z - 1) (so B_1 = -1/2), from FLINT.
Rational bernoulli(unsigned long n);
/// 1/n!
Rational inverse_factorial(unsigned long n);

}  // namespace pgi
