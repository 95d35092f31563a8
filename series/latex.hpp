#pragma once
// Polynomials and numbers as LaTeX that fits the page: coefficients as fractions, x1 -> x_{1}, exponents in
// braces, long polynomials broken at + and - signs by an estimate of their printed width.
#include "series/poly.hpp"

#include <string>
#include <vector>

namespace pgi {

/// The LaTeX form of a variable name: a trailing run of digits becomes a subscript ("x12" -> "x_{12}",
/// "p_x1" -> "p_{x_{1}}"), underscores become subscripts.
std::string latex_name(const std::string& name);
/// f in LaTeX math mode, terms in FLINT's order ("0" for zero).
std::string to_latex(const Poly& f);

/// One term of a polynomial with its sign ("+ \tfrac{1}{2} x_{1}^{2}", the first without "+") and the
/// estimated width of its display-style rendering in em of the body font (Computer Modern metrics:
/// digits 0.5 em, italic letters about 0.55, script sizes 0.7 of that, a binary sign with its spaces 1.25).
struct LatexTerm {
    std::string text;
    double width;
};
/// f's terms, in FLINT's order; coefficients whose numerator and denominator have at most 6 digits are
/// text-style fractions (\tfrac), larger ones display fractions. Zero has the single term "0".
std::vector<LatexTerm> latex_terms(const Poly& f);
/// f broken before + and - signs into lines whose estimated width is at most first_width (the first line)
/// and width (the others, em); a term wider than a whole line gets a line of its own.
std::vector<std::string> latex_lines(const Poly& f, double first_width, double width);

/// A double as a LaTeX number in math mode: "0.1", "-3", "6.266\times 10^{-12}" (significant digits,
/// scientific notation below 1e-3 and from 1e5 on), "\infty", "\mathrm{NaN}".
std::string latex_number(double x, int significant = 4);

}  // namespace pgi
