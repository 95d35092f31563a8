#include "series/latex.hpp"

#include <cctype>

namespace pgi {

std::string latex_name(const std::string& name) {
    if (auto u = name.find('_'); u != std::string::npos) {
        // a subscript needs a base that is not itself subscripted and a non-empty subscript ("x_", "_y",
        // "x1_a" would be a double subscript): anything else is set upright, underscores escaped
        if (u == 0 || u + 1 == name.size() || std::isdigit(static_cast<unsigned char>(name[u - 1]))) {
            std::string out = "\\mathrm{";
            for (char c : name) out += c == '_' ? std::string("\\_") : std::string(1, c);
            return out + "}";
        }
        return latex_name(name.substr(0, u)) + "_{" + latex_name(name.substr(u + 1)) + "}";
    }
    std::size_t d = name.size();
    while (d > 0 && std::isdigit(static_cast<unsigned char>(name[d - 1]))) --d;
    if (d == 0 || d == name.size()) return name;
    return name.substr(0, d) + "_{" + name.substr(d) + "}";
}

std::string to_latex(const Poly& f) { return to_latex(f, 0, ""); }

std::string to_latex(const Poly& f, std::size_t per_line, const std::string& separator) {
    if (f.is_zero()) return "0";
    std::string out;
    for (std::size_t t = 0; t < f.length(); ++t) {
        if (per_line > 0 && t > 0 && t % per_line == 0) out += separator;
        Rational c = f.term_coeff(t);
        const bool negative = fmpq_sgn(c.get()) < 0;
        if (negative) c = -c;
        out += t == 0 ? (negative ? "-" : "") : (negative ? " - " : " + ");
        const auto e = f.term_exponents(t);
        bool monomial = false;
        std::string vars;
        for (std::size_t v = 0; v < e.size(); ++v) {
            if (e[v] == 0) continue;
            monomial = true;
            vars += (vars.empty() ? "" : " ") + latex_name(f.ring()->names()[v]);
            if (e[v] > 1) vars += "^{" + std::to_string(e[v]) + "}";
        }
        const std::string num = c.to_string();
        const auto slash = num.find('/');
        if (slash != std::string::npos) out += "\\frac{" + num.substr(0, slash) + "}{" + num.substr(slash + 1) + "}" + (monomial ? " " : "");
        else if (num != "1" || !monomial) out += num + (monomial ? " " : "");
        out += vars;
    }
    return out;
}

}  // namespace pgi
