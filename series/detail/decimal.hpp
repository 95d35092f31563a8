#pragma once
// The extent of a decimal literal in a longer text, for readers that embed numbers (Poly::parse); the value is
// read by Rational::parse, exactly ("0.05" is 1/20), both in rational.cpp so the grammar is written once.
#include <cstddef>
#include <string_view>

namespace pgi {

/// The length of the unsigned decimal literal that text begins with, digits [. digits] [(e|E) [+-] digits]
/// (or . digits ...), 0 if it begins with none; an 'e' not followed by digits is not part of it ("2ex" gives 1).
std::size_t decimal_literal_length(std::string_view text);

}  // namespace pgi
