#include "series/rational.hpp"

#include "series/detail/decimal.hpp"

#include <flint/arith.h>
#include <flint/fmpz.h>
#include <gmp.h>
#include <mpfr.h>

#include <cctype>
#include <cmath>
#include <stdexcept>

namespace pgi {

Rational::Rational(long num, unsigned long den) : Rational() {
    if (den == 0) throw std::invalid_argument("pgi::Rational: zero denominator");
    fmpq_set_si(q_, num, den);
}

namespace {

bool all_digits(std::string_view s) {
    if (s.empty()) return false;
    for (char c : s)
        if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    return true;
}

std::string_view strip(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

[[noreturn]] void bad_number(std::string_view text, const std::string& why) {
    throw std::invalid_argument("'" + std::string(text) + "' is not a number (" + why + ")");
}

// |e| in a decimal's exponent beyond this is refused: 10^400 is far outside the double range, and the bound
// keeps the value's size within the text's length plus 400 digits.
constexpr long max_decimal_exponent = 400;

// 10^e as a Rational, e of either sign.
Rational power_of_ten(long e) {
    Rational r(1);
    fmpz_set_ui(fmpq_numref(r.get_mut()), 10);
    fmpz_pow_ui(fmpq_numref(r.get_mut()), fmpq_numref(r.get_mut()), static_cast<unsigned long>(std::labs(e)));
    if (e < 0) fmpq_inv(r.get_mut(), r.get_mut());
    return r;
}

Rational integer(std::string_view digits) {
    Rational r;
    fmpz_set_str(fmpq_numref(r.get_mut()), std::string(digits).c_str(), 10);
    return r;
}

// [sign] digits [. digits] [e|E [sign] digits]
Rational parse_decimal(std::string_view text) {
    std::string_view s = text;
    bool negative = false;
    if (!s.empty() && (s[0] == '-' || s[0] == '+')) {
        negative = s[0] == '-';
        s.remove_prefix(1);
    }
    long exponent = 0;
    if (auto e = s.find_first_of("eE"); e != std::string_view::npos) {
        std::string_view ex = s.substr(e + 1);
        const bool eneg = !ex.empty() && ex[0] == '-';
        if (!ex.empty() && (ex[0] == '-' || ex[0] == '+')) ex.remove_prefix(1);
        if (!all_digits(ex)) bad_number(text, "malformed exponent");
        while (ex.size() > 1 && ex[0] == '0') ex.remove_prefix(1);
        if (ex.size() > 6 || std::stol(std::string(ex)) > max_decimal_exponent)
            bad_number(text,
                       "exponent out of range: at most " + std::to_string(max_decimal_exponent) + " in absolute value");
        exponent = std::stol(std::string(ex)) * (eneg ? -1 : 1);
        s = s.substr(0, e);
    }
    std::string digits(s);
    if (auto dot = s.find('.'); dot != std::string_view::npos) {
        std::string_view whole = s.substr(0, dot), frac = s.substr(dot + 1);
        if ((!whole.empty() && !all_digits(whole)) || (!frac.empty() && !all_digits(frac)) ||
            whole.size() + frac.size() == 0)
            bad_number(text, "malformed decimal");
        digits = std::string(whole) + std::string(frac);
        exponent -= static_cast<long>(frac.size());
    } else if (!all_digits(s)) {
        bad_number(text, "expected an integer, a decimal or a fraction a/b");
    }
    Rational r = integer(digits) * power_of_ten(exponent);
    return negative ? -r : r;
}

}  // namespace

std::size_t decimal_literal_length(std::string_view text) {
    auto digits_from = [&](std::size_t i) {
        while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
        return i;
    };
    std::size_t i = digits_from(0);
    const bool whole = i > 0;
    if (i < text.size() && text[i] == '.') {
        const std::size_t frac_end = digits_from(i + 1);
        if (!whole && frac_end == i + 1) return 0;  // '.' alone is no number
        i = frac_end;
    }
    if (i == 0) return 0;
    if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
        std::size_t j = i + 1;
        if (j < text.size() && (text[j] == '+' || text[j] == '-')) ++j;
        if (const std::size_t end = digits_from(j); end > j) i = end;  // "2e" without digits ends before 'e'
    }
    return i;
}

Rational Rational::parse(std::string_view text) {
    std::string_view s = strip(text);
    if (s.empty()) bad_number(text, "empty");
    auto slash = s.find('/');
    if (slash == std::string_view::npos) return parse_decimal(s);
    Rational num = parse_decimal(strip(s.substr(0, slash)));
    Rational den = parse_decimal(strip(s.substr(slash + 1)));
    if (den.is_zero()) bad_number(text, "zero denominator");
    return num / den;
}

Rational Rational::from_double(double v) {
    if (!std::isfinite(v)) throw std::invalid_argument("pgi::Rational::from_double: non-finite value");
    Rational r;
    int e = 0;
    double m = std::frexp(v, &e);                             // v = m * 2^e, 0.5 <= |m| < 1
    fmpz_set_d(fmpq_numref(r.get_mut()), std::ldexp(m, 53));  // exact: 53-bit integer
    e -= 53;
    if (e >= 0) {
        fmpz_mul_2exp(fmpq_numref(r.get_mut()), fmpq_numref(r.get_mut()), static_cast<unsigned long>(e));
    } else {
        fmpz_one(fmpq_denref(r.get_mut()));
        fmpz_mul_2exp(fmpq_denref(r.get_mut()), fmpq_denref(r.get_mut()), static_cast<unsigned long>(-e));
        fmpq_canonicalise(r.get_mut());
    }
    return r;
}

double Rational::to_double() const {
    // NOTE: fmpq_get_d is not documented as correctly rounded; MPFR's mpfr_set_q is.
    mpq_t q;
    mpq_init(q);
    fmpq_get_mpq(q, q_);
    mpfr_t f;
    mpfr_init2(f, 53);
    mpfr_set_q(f, q, MPFR_RNDN);
    double d = mpfr_get_d(f, MPFR_RNDN);
    mpfr_clear(f);
    mpq_clear(q);
    return d;
}

std::string Rational::to_string() const {
    char* s = fmpq_get_str(nullptr, 10, q_);
    std::string out(s);
    flint_free(s);
    return out;
}

Rational operator+(const Rational& a, const Rational& b) {
    Rational r;
    fmpq_add(r.q_, a.q_, b.q_);
    return r;
}
Rational operator-(const Rational& a, const Rational& b) {
    Rational r;
    fmpq_sub(r.q_, a.q_, b.q_);
    return r;
}
Rational operator*(const Rational& a, const Rational& b) {
    Rational r;
    fmpq_mul(r.q_, a.q_, b.q_);
    return r;
}
Rational operator-(const Rational& a) {
    Rational r;
    fmpq_neg(r.q_, a.q_);
    return r;
}
Rational operator/(const Rational& a, const Rational& b) {
    if (b.is_zero()) throw std::domain_error("pgi::Rational: division by zero");
    Rational r;
    fmpq_div(r.q_, a.q_, b.q_);
    return r;
}

Rational bernoulli(unsigned long n) {
    Rational r;
    arith_bernoulli_number(r.get_mut(), n);
    return r;
}

Rational inverse_factorial(unsigned long n) {
    Rational r(1);
    fmpz_fac_ui(fmpq_denref(r.get_mut()), n);
    return r;
}

}  // namespace pgi
