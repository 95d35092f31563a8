// Poly::parse: FLINT's fmpq_mpoly_set_str_pretty does the parsing; this file only guards it.
// NOTE: FLINT aborts the process on a division by zero inside its parser and happily builds
// x^(10^20); both must become errors, so the text is scanned first for what FLINT cannot refuse.
#include "series/poly.hpp"

#include <cctype>

namespace pgi {

namespace {

class Guard {
public:
    Guard(const RingPtr& r, std::string_view text, unsigned long max_exponent)
        : ring_(r), text_(text), max_exponent_(max_exponent) {}

    void run() {
        const auto multiplier = group_multipliers();
        long depth = 0;
        std::vector<unsigned long> scale{1};  // product of the powers the enclosing groups are raised to
        for (std::size_t i = 0; i < text_.size();) {
            char c = text_[i];
            if (std::isspace(static_cast<unsigned char>(c))) { ++i; continue; }
            if (c == '(') {
                ++depth;
                scale.push_back(scale.back() * multiplier.at(i));
                ++i;
                continue;
            }
            if (c == ')') {
                if (--depth < 0) fail("unbalanced parentheses: ')' without '(' at position " + pos(i));
                scale.pop_back();
                ++i;
                continue;
            }
            if (c == '^') { i = check_exponent(i + 1, scale.back()); continue; }
            if (c == '/') { i = check_divisor(i + 1); continue; }
            if (c == '+' || c == '-' || c == '*') { ++i; continue; }
            if (std::isdigit(static_cast<unsigned char>(c))) { i = skip_number(i); continue; }
            if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
                std::size_t j = skip_identifier(i);
                std::string_view name = text_.substr(i, j - i);
                if (ring_->index_of(name) < 0) fail("unknown variable '" + std::string(name) + "'");
                i = j;
                continue;
            }
            fail(std::string("unexpected character '") + c + "' at position " + pos(i) +
                 (c == '.' ? " (write decimal coefficients as fractions, e.g. 3/2)" : ""));
        }
        if (depth != 0) fail("unbalanced parentheses: " + std::to_string(depth) + " '(' not closed");
    }

private:
    [[noreturn]] void fail(const std::string& why) const {
        throw ParseError("malformed polynomial '" + std::string(text_) + "': " + why);
    }
    std::string pos(std::size_t i) const { return std::to_string(i + 1); }

    std::size_t skip_space(std::size_t i) const {
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

    // After '^': a non-negative integer literal n with n times the powers of the enclosing groups at most
    // max_exponent_ (so neither x^1001 nor ((x+1)^100)^100 nor 7^777^7 is built), not itself raised to a power.
    std::size_t check_exponent(std::size_t i, unsigned long enclosing) const {
        i = skip_space(i);
        std::size_t j = skip_number(i);
        if (j == i) fail("'^' must be followed by a non-negative integer at position " + pos(i));
        std::string_view digits = text_.substr(i, j - i);
        if (digits.size() > 18 || std::stoul(std::string(digits)) > max_exponent_)
            fail("exponent " + std::string(digits) + " exceeds the limit " + std::to_string(max_exponent_));
        if (std::stoul(std::string(digits)) * enclosing > max_exponent_)
            fail("exponent " + std::string(digits) + " inside groups raised to the power " + std::to_string(enclosing) +
                 " exceeds the limit " + std::to_string(max_exponent_));
        if (std::size_t k = skip_space(j); k < text_.size() && text_[k] == '^')
            fail("chained exponents at position " + pos(k) + ": write (a^b)^c");
        return j;
    }

    // For each '(' the power its group is raised to (1 when none), capped so products cannot overflow.
    std::vector<unsigned long> group_multipliers() const {
        std::vector<unsigned long> m(text_.size(), 1);
        std::vector<std::size_t> open;
        for (std::size_t i = 0; i < text_.size(); ++i) {
            if (text_[i] == '(') open.push_back(i);
            if (text_[i] != ')' || open.empty()) continue;
            std::size_t k = skip_space(i + 1);
            if (k < text_.size() && text_[k] == '^') {
                std::size_t a = skip_space(k + 1), b = skip_number(a);
                std::string_view digits = text_.substr(a, b - a);
                if (!digits.empty()) m[open.back()] = digits.size() > 6 ? max_exponent_ + 1 : std::stoul(std::string(digits));
            }
            open.pop_back();
        }
        for (auto& v : m) v = std::max<unsigned long>(1, std::min<unsigned long>(v, max_exponent_ + 1));
        return m;
    }

    // After '/': the divisor must be a non-zero constant (a number or a parenthesised constant).
    std::size_t check_divisor(std::size_t i) const {
        i = skip_space(i);
        while (i < text_.size() && (text_[i] == '-' || text_[i] == '+')) i = skip_space(i + 1);
        if (i >= text_.size()) fail("'/' without a divisor");
        if (std::isdigit(static_cast<unsigned char>(text_[i]))) {
            std::size_t j = skip_number(i);
            if (text_.substr(i, j - i).find_first_not_of('0') == std::string_view::npos) fail("division by zero");
            return j;
        }
        if (text_[i] == '(') {
            std::size_t close = matching(i);
            Poly d = Poly::parse(ring_, text_.substr(i + 1, close - i - 1), max_exponent_);
            if (d.is_zero()) fail("division by zero");
            if (d.total_degree() > 0) fail("division by the non-constant '" + d.to_string() + "'");
            return close + 1;
        }
        std::size_t j = skip_identifier(i);
        if (j > i) fail("division by the variable '" + std::string(text_.substr(i, j - i)) + "' (only constants may divide)");
        return i;  // let FLINT report the syntax error
    }

    std::size_t matching(std::size_t open) const {
        long depth = 0;
        for (std::size_t i = open; i < text_.size(); ++i) {
            if (text_[i] == '(') ++depth;
            if (text_[i] == ')' && --depth == 0) return i;
        }
        fail("unbalanced parentheses: '(' at position " + pos(open) + " not closed");
    }

    const RingPtr& ring_;
    std::string_view text_;
    unsigned long max_exponent_;
};

}  // namespace

Poly Poly::parse(RingPtr r, std::string_view text, unsigned long max_exponent) {
    Guard(r, text, max_exponent).run();
    if (text.find_first_not_of(" \t\r\n") == std::string_view::npos)
        throw ParseError("malformed polynomial '" + std::string(text) + "': empty");
    std::vector<const char*> names;
    for (const auto& n : r->names()) names.push_back(n.c_str());
    Poly p(std::move(r));
    std::string s(text);
    if (fmpq_mpoly_set_str_pretty(p.get_mut(), s.c_str(), names.data(), p.ctx()) != 0)
        throw ParseError("malformed polynomial '" + s + "': syntax error");
    return p;
}

}  // namespace pgi
