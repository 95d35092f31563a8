#pragma once
// A polynomial as LaTeX: \frac{a}{b} coefficients, x1 -> x_{1}, exponents in braces.
#include "series/poly.hpp"

#include <string>

namespace pgi {

/// The LaTeX form of a variable name: a trailing run of digits becomes a subscript ("x12" -> "x_{12}",
/// "p_x1" -> "p_{x_{1}}"), underscores become subscripts.
std::string latex_name(const std::string& name);
/// f in LaTeX math mode, terms in FLINT's order ("0" for zero).
std::string to_latex(const Poly& f);
/// The same, broken after every `per_line` terms with `separator` (e.g. "\\\\ &\\quad " inside align).
std::string to_latex(const Poly& f, std::size_t per_line, const std::string& separator);

}  // namespace pgi
