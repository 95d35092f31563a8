#include "series/latex.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <utility>

namespace pgi {

namespace {

constexpr double digit_em = 0.5, letter_em = 0.55, script = 0.7, sign_em = 1.25, fraction_pad_em = 0.3;

// a variable name in LaTeX and its printed width: a trailing run of digits and the part after an
// underscore become subscripts (at script size)
std::pair<std::string, double> typeset_name(const std::string& name, double scale) {
    if (auto u = name.find('_'); u != std::string::npos) {
        // a subscript needs a base that is not itself subscripted and a non-empty subscript ("x_", "_y",
        // "x1_a" would be a double subscript): anything else is set upright, underscores escaped
        if (u == 0 || u + 1 == name.size() || std::isdigit(static_cast<unsigned char>(name[u - 1]))) {
            std::string out = "\\mathrm{";
            for (char c : name) out += c == '_' ? std::string("\\_") : std::string(1, c);
            return {out + "}", scale * letter_em * double(name.size())};
        }
        const auto [base, wb] = typeset_name(name.substr(0, u), scale);
        const auto [sub, ws] = typeset_name(name.substr(u + 1), scale * script);
        return {base + "_{" + sub + "}", wb + ws};
    }
    std::size_t d = name.size();
    while (d > 0 && std::isdigit(static_cast<unsigned char>(name[d - 1]))) --d;
    if (d == 0 || d == name.size()) return {name, scale * letter_em * double(name.size())};
    return {name.substr(0, d) + "_{" + name.substr(d) + "}",
            scale * (letter_em * double(d) + script * digit_em * double(name.size() - d))};
}

std::string coefficient_latex(const Rational& c, bool monomial, double& width) {
    const std::string num = c.to_string();
    const auto slash = num.find('/');
    if (slash == std::string::npos) {
        if (num == "1" && monomial) return "";
        width += digit_em * double(num.size());
        return num + (monomial ? " " : "");
    }
    const std::string p = num.substr(0, slash), q = num.substr(slash + 1);
    const bool small = p.size() <= 6 && q.size() <= 6;
    width += (small ? script : 1.0) * digit_em * double(std::max(p.size(), q.size())) + fraction_pad_em;
    return (small ? "\\tfrac{" : "\\frac{") + p + "}{" + q + "}" + (monomial ? " " : "");
}

}  // namespace

std::string latex_name(const std::string& name) {
    return typeset_name(name, 1.0).first;
}

std::vector<LatexTerm> latex_terms(const Poly& f) {
    if (f.is_zero()) return {{"0", digit_em}};
    std::vector<LatexTerm> terms;
    for (std::size_t t = 0; t < f.length(); ++t) {
        Rational c = f.term_coeff(t);
        const bool negative = fmpq_sgn(c.get()) < 0;
        if (negative) c = -c;
        LatexTerm term{t == 0 ? (negative ? "-" : "") : (negative ? "- " : "+ "), t == 0 && !negative ? 0.0 : sign_em};
        const auto e = f.term_exponents(t);
        std::string vars;
        for (std::size_t v = 0; v < e.size(); ++v) {
            if (e[v] == 0) continue;
            const auto [text, width] = typeset_name(f.ring()->names()[v], 1.0);
            vars += (vars.empty() ? "" : " ") + text;
            term.width += width;
            if (e[v] > 1) {
                const std::string k = std::to_string(e[v]);
                vars += "^{" + k + "}";
                term.width += script * digit_em * double(k.size());
            }
        }
        term.text += coefficient_latex(c, !vars.empty(), term.width) + vars;
        terms.push_back(std::move(term));
    }
    return terms;
}

std::string to_latex(const Poly& f) {
    std::string out;
    for (const auto& t : latex_terms(f)) out += (out.empty() ? "" : " ") + t.text;
    return out;
}

std::vector<std::string> latex_lines(const Poly& f, double first_width, double width) {
    std::vector<std::string> lines{""};
    double used = 0;
    for (const auto& t : latex_terms(f)) {
        const double room = lines.size() == 1 ? first_width : width;
        if (!lines.back().empty() && used + t.width > room) {
            lines.emplace_back();
            used = 0;
        }
        lines.back() += (lines.back().empty() ? "" : " ") + t.text;
        used += t.width;
    }
    return lines;
}

std::string latex_number(double x, int significant) {
    if (std::isnan(x)) return "\\mathrm{NaN}";
    if (std::isinf(x)) return x > 0 ? "\\infty" : "-\\infty";
    if (x == 0) return "0";
    const double a = std::abs(x);
    char buffer[64];
    if (a >= 1e-3 && a < 1e5) {
        std::snprintf(buffer, sizeof buffer, "%.*g", significant, x);
        return buffer;
    }
    // d.ddd x 10^{e}: the mantissa rounded first, so 9.9999e-5 becomes 1 x 10^{-4}
    std::snprintf(buffer, sizeof buffer, "%.*e", significant - 1, x);
    const std::string s = buffer;
    const auto e = s.find('e');
    std::string mantissa = s.substr(0, e);
    if (mantissa.find('.') != std::string::npos) {
        while (mantissa.back() == '0') mantissa.pop_back();
        if (mantissa.back() == '.') mantissa.pop_back();
    }
    const int exponent = std::stoi(s.substr(e + 1));
    return (mantissa == "1"    ? ""
            : mantissa == "-1" ? "-"
                               : mantissa + "\\times ") +
           "10^{" + std::to_string(exponent) + "}";
}

}  // namespace pgi
