// CSV numbers: the shortest text that reads back to the same double.
#include "tools/csv.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>

using namespace pgi;

namespace {

std::uint64_t bits(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
}

// The fewest significant digits p (1..17) with which %.{p}g reads back to v: an independent bound.
int fewest_digits(double v) {
    char buf[64];
    for (int p = 1; p < 17; ++p) {
        std::snprintf(buf, sizeof buf, "%.*g", p, v);
        if (bits(std::strtod(buf, nullptr)) == bits(v)) return p;
    }
    return 17;
}

// The significant digits of a number's text: those of its mantissa, without leading and trailing zeros.
int significant_digits(const std::string& text) {
    std::string digits;
    for (char c : text.substr(0, text.find('e')))
        if (c >= '0' && c <= '9') digits += c;
    const auto first = digits.find_first_not_of('0'), last = digits.find_last_not_of('0');
    return first == std::string::npos ? 1 : int(last - first + 1);
}

}  // namespace

TEST_CASE("csv numbers read back bit for bit with the fewest significant digits that do") {
    CHECK(csv_number(0.6) == "0.6");
    CHECK(csv_number(0.1 + 0.2) == "0.30000000000000004");
    CHECK(csv_number(100) == "100");
    CHECK(csv_number(-0.0) == "-0");
    CHECK(csv_number(std::numeric_limits<double>::denorm_min()) == "5e-324");
    CHECK(csv_number(std::numeric_limits<double>::quiet_NaN()) == "nan");
    CHECK(csv_number(-std::numeric_limits<double>::infinity()) == "-inf");
    std::mt19937_64 gen(20261127);
    std::uniform_real_distribution<double> unit(-1, 1);
    for (int i = 0; i < 200000; ++i) {
        double v;
        if (i % 2) {
            const std::uint64_t b = gen();
            std::memcpy(&v, &b, sizeof v);  // any bit pattern: every exponent, subnormals
        } else {
            v = unit(gen) * std::pow(10.0, double(int(gen() % 40) - 20));  // the sizes a run prints
        }
        if (!std::isfinite(v)) continue;
        const std::string text = csv_number(v);
        CAPTURE(text);
        REQUIRE(bits(std::strtod(text.c_str(), nullptr)) == bits(v));
        REQUIRE(significant_digits(text) <= fewest_digits(v));
        REQUIRE(text.size() <= 24);  // sign, 17 digits, point, e-308
    }
}
