#pragma once
// Numeric command-line values read strictly: the whole text is one finite number in a stated range, so
// "nan", "-1", "1e9" for a degree or "4x" never wrap around, disable a guard or reach an allocation.
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace pgi {

/// The double written in text (decimal, possibly with an exponent), finite, or nullopt-like NaN.
inline double strict_double(const std::string& text) {
    if (text.empty() ||
        !(std::isdigit(static_cast<unsigned char>(text[0])) || text[0] == '.' || text[0] == '-' || text[0] == '+'))
        return std::nan("");
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    return end == text.c_str() + text.size() && std::isfinite(v) ? v : std::nan("");
}

/// A whole number in [lo, hi] (hi <= 2^53), written in digits or as an exact decimal like 1e8.
/// Throws std::invalid_argument "OPTION: 'TEXT' is not a whole number from LO to HI".
inline std::size_t whole_number(const std::string& option, const std::string& text, std::size_t lo, std::size_t hi) {
    const double v = strict_double(text);
    if (!(v >= double(lo) && v <= double(hi)) || v != std::floor(v))
        throw std::invalid_argument(option + ": '" + text + "' is not a whole number from " + std::to_string(lo) +
                                    " to " + std::to_string(hi));
    return static_cast<std::size_t>(v);
}

/// A finite number with 0 < value <= hi. Throws std::invalid_argument naming the option.
inline double positive_number(const std::string& option, const std::string& text, double hi) {
    const double v = strict_double(text);
    if (!(v > 0 && v <= hi))
        throw std::invalid_argument(option + ": '" + text + "' is not a number above 0 and at most " +
                                    std::to_string(long(hi)));
    return v;
}

/// Finite numbers separated by commas, spaces or line breaks (a --t-eval list or file). Throws
/// std::invalid_argument naming the option, the item's position and its text (its first 40 characters).
inline std::vector<double> number_list(const std::string& option, const std::string& text) {
    std::vector<double> out;
    std::size_t i = 0;
    while (i < text.size()) {
        const std::size_t end = text.find_first_of(", \t\r\n", i);
        const std::string item = text.substr(i, end == std::string::npos ? std::string::npos : end - i);
        i = end == std::string::npos ? text.size() : end + 1;
        if (item.empty()) continue;
        const double v = strict_double(item);
        if (!std::isfinite(v))
            throw std::invalid_argument(option + ": item " + std::to_string(out.size() + 1) + " '" +
                                        item.substr(0, 40) + "' is not a finite number");
        out.push_back(v);
    }
    if (out.empty()) throw std::invalid_argument(option + ": no times given");
    return out;
}

}  // namespace pgi
