#pragma once
// Numbers in pgi's CSV files (a run's trajectory, an ensemble's table, a section's crossings): the shortest text that
// reads back to the same double, as the JSON documents print them.
#include <fmt/format.h>

#include <string>

namespace pgi {

/// v in the shortest form that strtod reads back to v bit for bit ("0.6", not "0.59999999999999998"; "-0" keeps the
/// sign); "nan", "inf" and "-inf" for the non-finite.
inline std::string csv_number(double v) {
    return fmt::format("{}", v);
}

}  // namespace pgi
