#include "series/series.hpp"

#include <doctest/doctest.h>

using namespace pgi;

namespace {

// The p-graded series of f in the ring (x, p), truncated after degree N - 1.
Series in_p(const Poly& f, std::size_t N) { return Series::graded(f, {false, true}, N); }

}  // namespace

TEST_CASE("series: mul_trunc is the product truncated") {
    auto r = make_ring({"x", "p"});
    Poly f = Poly::parse(r, "x + x*p + 2*p^2 - p^3"), g = Poly::parse(r, "1 - x*p + p^2*x^2 + p^4");
    for (std::size_t N : {1u, 2u, 3u, 5u, 8u}) {
        CAPTURE(N);
        CHECK(mul_trunc(in_p(f, N), in_p(g, N)) == in_p(f * g, N));
    }
}

TEST_CASE("series: compose is substitution followed by truncation") {
    auto r = make_ring({"x", "p"});
    Poly f = Poly::parse(r, "x^3 - 2*x + 1/2");
    Poly image = Poly::parse(r, "x + x*p - 1/3*p^2 + p^3");
    for (std::size_t N : {1u, 3u, 6u}) {
        std::vector<std::optional<Series>> images{in_p(image, N), std::nullopt};
        CHECK(compose(f, images, N) == in_p(substitute(f, {image, Poly::gen(r, 1)}), N));
    }
}

TEST_CASE("series: kept variables stay as they are") {
    auto r = make_ring({"x", "t"});
    // t-series in the implicit variable: images of x only, the x in f's other factor is kept.
    Poly f = Poly::parse(r, "3*x");
    Series s(r, 3);
    s[1] = Poly::parse(r, "x");
    std::vector<std::optional<Series>> none{std::nullopt, std::nullopt};
    CHECK(compose(f, none, 3)[0] == f);
    std::vector<std::optional<Series>> images{s, std::nullopt};
    CHECK(compose(Poly::parse(r, "x^2"), images, 3)[2] == Poly::parse(r, "x^2"));
    CHECK(compose(Poly::parse(r, "x^2"), images, 3)[1].is_zero());
}

TEST_CASE("series: mixing truncation orders is refused") {
    auto r = make_ring({"x", "p"});
    CHECK_THROWS_WITH_AS(mul_trunc(Series(r, 2), Series(r, 3)), "pgi::mul_trunc: truncation orders differ (2 and 3)",
                         std::invalid_argument);
    CHECK_THROWS_AS(Series(r, 2) + Series(r, 3), std::invalid_argument);
    CHECK_THROWS_AS(Series(r, 2).truncated(3), std::invalid_argument);
}
