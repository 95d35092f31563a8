// Poly::parse: a recursive-descent reader that builds the polynomial with pgi's own operations, so every
// product and power is estimated by the ring's budget before it is formed, and every error has a position.
// NOTE: FLINT's fmpq_mpoly_set_str_pretty cannot be bounded: it aborts the process on a division by zero,
// expands (x1+...+x6)^1000 until memory runs out and recurses without limit; hence this reader.
//   expression := term (('+' | '-') term)*
//   term       := unary (('*' | '/') unary)*       (a divisor must be a non-zero constant)
//   unary      := ('+' | '-') unary | power
//   power      := atom ['^' integer]                 (no chained exponents: write (a^b)^c)
//   atom       := number | variable | '(' expression ')'
//   number     := digits ['.' digits] [('e'|'E') ['+'|'-'] digits], exactly: 0.05 is 1/20 (Rational::parse)
#include "series/poly.hpp"

#include "series/detail/decimal.hpp"

#include <algorithm>
#include <cctype>

namespace pgi {

namespace {

// A value read so far and the product of the exponents applied inside it (the "scale" of its powers):
// ((x)^10)^10 has scale 100, which max_exponent bounds like a single x^100.
struct Operand {
    Poly value;
    unsigned long scale = 1;
};

class Reader {
public:
    Reader(const RingPtr& r, std::string_view text, unsigned long max_exponent)
        : ring_(r), text_(text), max_exponent_(max_exponent) {}

    Poly read() {
        try {
            if (skip_space() == text_.size()) fail("empty");
            Operand e = expression();
            if (skip_space() < text_.size()) {
                const char c = text_[i_];
                if (c == ')') fail("unbalanced parentheses: ')' without '(' at position " + pos(i_));
                if (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '(')
                    fail("syntax error at position " + pos(i_) + ": expected an operator");
                unexpected(c);
            }
            return std::move(e.value);
        } catch (const ResourceLimitError& e) {
            throw ParseBudgetError("polynomial '" + quoted() + "': expanding the '" + std::string(1, text_[op_]) +
                                   "' at position " + pos(op_) + ": " + e.what());
        }
    }

private:
    // Nesting of parentheses and signs (a division's divisor nests through them), bounded by max_parse_depth.
    class Nested {
    public:
        explicit Nested(Reader& r) : r_(r) {
            if (++r_.depth_ > max_parse_depth)
                r_.fail("nesting deeper than " + std::to_string(max_parse_depth) +
                        " (parentheses and signs) at position " + r_.pos(r_.i_));
        }
        ~Nested() { --r_.depth_; }
        Nested(const Nested&) = delete;
        Nested& operator=(const Nested&) = delete;

    private:
        Reader& r_;
    };

    // The terms are added once, in pairs (pgi::sum): added one by one, H = x1 + ... + xn would copy a growing
    // sum n times (and, stored locally, move it to more variables each time).
    Operand expression() {
        Operand a = term();
        std::vector<Poly> terms;
        while (skip_space() < text_.size() && (text_[i_] == '+' || text_[i_] == '-')) {
            const std::size_t at = i_++;
            Operand b = term();
            op_ = at;
            if (terms.empty()) terms.push_back(std::move(a.value));
            terms.push_back(text_[at] == '-' ? -b.value : std::move(b.value));
            a.scale = std::max(a.scale, b.scale);
        }
        if (!terms.empty()) a.value = sum(std::move(terms), ring_);
        return a;
    }

    Operand term() {
        Operand a = unary();
        while (skip_space() < text_.size() && (text_[i_] == '*' || text_[i_] == '/')) {
            const std::size_t at = i_++;
            if (text_[at] == '/') {
                Rational inverse = divisor();
                op_ = at;
                a.value *= inverse;
                continue;
            }
            Operand b = unary();
            op_ = at;
            check_degree(a.value.total_degree() + b.value.total_degree(), "a product", at);
            a.value = a.value * b.value;
            a.scale = std::max(a.scale, b.scale);
        }
        return a;
    }

    // Every polynomial read has total degree at most max_exponent, however its factors were written: x^1000 * x^1000
    // and (x1 x2)^600 are refused as x^2000 is, before anything is expanded (deeper, the compiled maps' monomial
    // chains and the exact phase's products grow without a use).
    void check_degree(long degree, const char* what, std::size_t at) const {
        if (degree > long(max_exponent_))
            fail(std::string(what) + " of degree " + std::to_string(degree) + " exceeds the degree limit " +
                 std::to_string(max_exponent_) + " (at position " + pos(at) + ")");
    }

    // After '/': the reciprocal of a non-zero constant.
    Rational divisor() {
        const std::size_t start = skip_space();
        Operand d = unary();
        if (d.value.total_degree() > 0) {
            const std::string_view name = text_.substr(start, skip_identifier(start) - start);
            if (!name.empty() && d.value == Poly::gen(ring_, static_cast<std::size_t>(ring_->index_of(name))))
                fail("division by the variable '" + std::string(name) + "' at position " + pos(start) +
                     " (only constants may divide)");
            fail("division by the non-constant '" + d.value.to_string() + "' at position " + pos(start));
        }
        if (d.value.is_zero()) fail("division by zero at position " + pos(start));
        return Rational(1) / d.value.term_coeff(0);
    }

    Operand unary() {
        if (skip_space() < text_.size() && (text_[i_] == '-' || text_[i_] == '+')) {
            Nested guard(*this);
            const std::size_t at = i_++;
            Operand a = unary();
            if (text_[at] == '-') {
                op_ = at;
                a.value = -a.value;
            }
            return a;
        }
        return power();
    }

    Operand power() {
        Operand a = atom();
        if (skip_space() >= text_.size() || text_[i_] != '^') return a;
        const std::size_t at = i_++;
        const std::size_t start = skip_space(), end = skip_number(start);
        if (end == start) fail("'^' must be followed by a non-negative integer at position " + pos(start));
        const std::string digits(text_.substr(start, end - start));
        if (digits.size() > 18 || std::stoul(digits) > max_exponent_)
            fail("exponent " + digits + " exceeds the limit " + std::to_string(max_exponent_) + " (at position " +
                 pos(start) + ")");
        const unsigned long n = std::stoul(digits);
        if (n != 0 && a.scale > max_exponent_ / n)
            fail("exponent " + std::to_string(a.scale) + " inside groups raised to the power " + digits +
                 " exceeds the limit " + std::to_string(max_exponent_) + " (at position " + pos(start) + ")");
        if (end < text_.size() && (text_[end] == '.' || decimal_literal_length(text_.substr(start)) > end - start))
            fail("'^' must be followed by a non-negative integer at position " + pos(start) + ", not a decimal");
        check_degree(a.value.total_degree() * long(n), "a power", at);
        i_ = end;
        if (skip_space() < text_.size() && text_[i_] == '^')
            fail("chained exponents at position " + pos(i_) + ": write (a^b)^c");
        op_ = at;
        return {pow(a.value, n), std::max<unsigned long>(1, a.scale * n)};
    }

    Operand atom() {
        if (skip_space() >= text_.size()) fail("syntax error at the end: expected a number, a variable or '('");
        const char c = text_[i_];
        if (c == '(') {
            Nested guard(*this);
            const std::size_t open = i_++;
            Operand e = expression();
            if (skip_space() >= text_.size() || text_[i_] != ')')
                fail("unbalanced parentheses: '(' at position " + pos(open) + " not closed");
            ++i_;
            return e;
        }
        if (const std::size_t length = decimal_literal_length(text_.substr(i_)); length > 0) {
            const std::string_view literal = text_.substr(i_, length);
            try {
                Rational value = Rational::parse(literal);
                i_ += length;
                return {Poly::constant(ring_, value)};
            } catch (const std::invalid_argument& e) {
                fail(std::string(e.what()) + " at position " + pos(i_));
            }
        }
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
            const std::size_t end = skip_identifier(i_);
            const std::string_view name = text_.substr(i_, end - i_);
            const long v = ring_->index_of(name);
            if (v < 0) fail("unknown variable '" + std::string(name) + "' at position " + pos(i_));
            i_ = end;
            return {Poly::gen(ring_, static_cast<std::size_t>(v))};
        }
        if (c == ')' || c == '*' || c == '/' || c == '^')
            fail(std::string("syntax error at position ") + pos(i_) +
                 ": expected a number, a variable or '(' before '" + c + "'");
        unexpected(c);
    }

    [[noreturn]] void unexpected(char c) const {
        fail(std::string("unexpected character '") + printable(c) + "' at position " + pos(i_));
    }

    [[noreturn]] void fail(const std::string& why) const {
        throw ParseError("malformed polynomial '" + quoted() + "': " + why);
    }
    // The text for messages: at most 60 characters, control characters shown as '?'.
    std::string quoted() const {
        std::string s;
        for (char c : text_.substr(0, 60)) s += printable(c);
        return text_.size() > 60 ? s + "..." : s;
    }
    static char printable(char c) { return std::isprint(static_cast<unsigned char>(c)) ? c : '?'; }
    std::string pos(std::size_t i) const { return std::to_string(i + 1); }

    std::size_t skip_space() { return i_ = skip_space_from(i_); }
    std::size_t skip_space_from(std::size_t i) const {
        while (i < text_.size() && std::isspace(static_cast<unsigned char>(text_[i]))) ++i;
        return i;
    }
    std::size_t skip_number(std::size_t i) const {
        while (i < text_.size() && std::isdigit(static_cast<unsigned char>(text_[i]))) ++i;
        return i;
    }
    std::size_t skip_identifier(std::size_t i) const {
        while (i < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[i])) || text_[i] == '_')) ++i;
        return i;
    }

    const RingPtr& ring_;
    std::string_view text_;
    unsigned long max_exponent_;
    std::size_t i_ = 0, op_ = 0, depth_ = 0;
};

}  // namespace

Poly Poly::parse(RingPtr r, std::string_view text, unsigned long max_exponent) {
    return Reader(r, text, max_exponent).read();
}

}  // namespace pgi
