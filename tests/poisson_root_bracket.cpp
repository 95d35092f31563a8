// The bracketed Newton root finder: round-off accuracy, the safeguard, and degenerate brackets.
#include "poisson/detail/root_bracket.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <utility>

using namespace pgi;

namespace {

const double eps = std::numeric_limits<double>::epsilon();

}  // namespace

TEST_CASE("root_bracket: x^3 - 2 on [0, 2] ends within two ulps of 2^(1/3), in few evaluations") {
    int calls = 0;
    auto f = [&](double x) {
        ++calls;
        return std::pair<double, double>{x * x * x - 2, 3 * x * x};
    };
    const double r = find_root(f, 0, 2, -2, 6);
    CHECK(std::abs(r - std::cbrt(2.0)) <= 2 * eps * std::cbrt(2.0));
    CHECK(calls <= 12);  // Newton converges quadratically once inside; bisection alone would take ~52
}

TEST_CASE("root_bracket: where Newton overshoots (atan, far from its root) the bracket keeps it") {
    // The regula falsi start is x = 3.22, where plain Newton on atan(x - 0.3) diverges (it does for
    // |x - 0.3| > 1.39); kept in the bracket [-1, 10] it converges.
    auto f = [](double x) { return std::pair<double, double>{std::atan(x - 0.3), 1 / (1 + (x - 0.3) * (x - 0.3))}; };
    const double r = find_root(f, -1, 10, std::atan(-1.3), std::atan(9.7));
    CHECK(std::abs(r - 0.3) <= 4 * eps);
}

TEST_CASE("root_bracket: a decreasing function, a zero at an end, and a useless derivative") {
    auto dec = [](double x) { return std::pair<double, double>{0.5 - x, -1.0}; };
    CHECK(find_root(dec, 0, 1, 0.5, -0.5) == 0.5);
    auto any = [](double) { return std::pair<double, double>{1.0, 1.0}; };
    CHECK(find_root(any, 0, 1, 0, 1) == 0);   // f(a) = 0
    CHECK(find_root(any, 0, 1, -1, 0) == 1);  // f(b) = 0
    // a derivative of 0 everywhere: Newton's step is infinite, bisection finds the root anyway
    auto flat = [](double x) { return std::pair<double, double>{x - 0.25, 0.0}; };
    CHECK(std::abs(find_root(flat, 0, 1, -0.25, 0.75) - 0.25) <= 4 * eps);
}
