#include "series/composition.hpp"

#include <doctest/doctest.h>

#include <random>

using namespace pgi;

namespace {

// The p-graded series of f in the ring (x, p), truncated after degree N - 1.
Series in_p(const Poly& f, std::size_t N) {
    return Series::graded(f, {false, true}, N);
}

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

TEST_CASE("series: inverse_near_identity inverts id + u to its order, stops where told, refuses u not O(e)") {
    auto r = make_ring({"x", "y"});
    const std::size_t N = 6;
    std::vector<Series> u(2, Series(r, N));
    const char* ux[] = {"0", "x*y + 1/2", "x^2 - y", "y^3", "2*x*y^2", "x - 1/7*y^2"};
    const char* uy[] = {"0", "y^2", "3*x", "x*y^2 - 1", "y^4", "x^2*y"};
    for (std::size_t m = 0; m < N; ++m) u[0][m] = Poly::parse(r, ux[m]), u[1][m] = Poly::parse(r, uy[m]);
    const auto v = inverse_near_identity(u, {0, 1}, N);
    REQUIRE(v.size() == 2);
    // (id + u) o (id + v) = id + O(e^N): u(id + v) + v = 0 through e^(N-1)
    std::vector<std::optional<Series>> images(2);
    for (std::size_t i = 0; i < 2; ++i) images[i] = Series::constant(Poly::gen(r, i), N) + v[i];
    const auto uv = compose(u, images, N);
    for (std::size_t i = 0; i < 2; ++i) CHECK(uv[i] + v[i] == Series(r, N));
    CHECK_FALSE(v[0][N - 1].is_zero());
    // told to stop after order 3, the result is the same series truncated there
    const auto w =
        inverse_near_identity(u, {0, 1}, N, [](const std::vector<Series>& s) { return s.front().order() == 4; });
    for (std::size_t i = 0; i < 2; ++i) CHECK(w[i] == v[i].truncated(4));
    u[1][0] = Poly::parse(r, "x");
    CHECK_THROWS_AS(inverse_near_identity(u, {0, 1}, N), std::invalid_argument);
}

TEST_CASE(
    "series: ComposeByOrder completed order by order equals compose of the finished images, and refuses to rewrite a "
    "read order") {
    auto r = make_ring({"x", "y", "p"});
    const std::size_t N = 5;
    // images of x and y whose coefficient m is given only once the compositions through m - 1 were read
    const char* ix[] = {"x", "p*y", "x^2 - p", "3*y*p^2", "x*y"};
    const char* iy[] = {"y + 1", "0", "x*p", "y^2", "p^3 - x"};
    std::vector<Poly> fs{Poly::parse(r, "x^3*y - 2*x*p + y^2"), Poly::parse(r, "p*x*y^2 + 1/3"),
                         Poly::parse(r, "y^4 + x")};
    std::vector<std::optional<Series>> empty(3), full(3);
    empty[0] = Series(r, N), empty[1] = Series(r, N), full[0] = Series(r, N), full[1] = Series(r, N);
    for (std::size_t m = 0; m < N; ++m) (*full[0])[m] = Poly::parse(r, ix[m]), (*full[1])[m] = Poly::parse(r, iy[m]);
    const auto expected = compose(fs, full, N);
    ComposeByOrder by_order(fs, empty, N);
    for (std::size_t m = 0; m < N; ++m) {
        by_order.set_image(0, m, Poly::parse(r, ix[m]));
        by_order.set_image(1, m, Poly::parse(r, iy[m]));
        for (std::size_t i = 0; i < fs.size(); ++i) CHECK(by_order.coefficient(i, m) == expected[i][m]);
        if (m > 0) CHECK_THROWS_AS(by_order.set_image(0, m, Poly(r)), std::logic_error);
    }
    CHECK_THROWS_AS(by_order.set_image(2, 0, Poly(r)), std::invalid_argument);  // p has no image
    CHECK_THROWS_AS(by_order.coefficient(0, N), std::out_of_range);

    // polynomials appended as the recursion goes (f_i after order i - 1 was read) share the products formed
    // before them and give compose's coefficients
    ComposeByOrder appended(r, empty, N);
    for (std::size_t m = 0; m < N; ++m) {
        if (m < fs.size()) CHECK(appended.append(fs[m]) == m);
        appended.set_image(0, m, Poly::parse(r, ix[m]));
        appended.set_image(1, m, Poly::parse(r, iy[m]));
        for (std::size_t i = 0; i < std::min(m + 1, fs.size()); ++i)
            CHECK(appended.coefficient(i, m) == expected[i][m]);
    }
    CHECK_THROWS_AS(appended.append(Poly(make_ring({"x", "y", "p"}))), std::invalid_argument);  // another ring
}

TEST_CASE(
    "series: compose of random polynomials is graded substitution, with kept variables and images of every degree") {
    // Identity test (FLINT style): for f in x, y, z and images of x and y graded by their degree in p,
    // compose(f, images, N) = the p-graded parts of f(gx, gy, z) below N; z is kept.
    auto r = make_ring({"x", "y", "z", "p"});
    const VarMask p_only{false, false, false, true};
    std::mt19937 gen(20261124);
    std::uniform_int_distribution<long> coeff(-5, 5);
    std::uniform_int_distribution<unsigned long> den(1, 4), ex(0, 2);
    auto random_poly = [&](int terms, bool with_p) {
        Poly f(r);
        for (int t = 0; t < terms; ++t) {
            Poly m = Poly::constant(r, Rational(coeff(gen), den(gen)));
            for (std::size_t v = 0; v < (with_p ? 4u : 3u); ++v) m = m * pow(Poly::gen(r, v), ex(gen));
            f += m;
        }
        return f;
    };
    for (int trial = 0; trial < 12; ++trial) {
        CAPTURE(trial);
        const Poly f = random_poly(5, false), gx = random_poly(4, true), gy = random_poly(3, true);
        const Poly substituted = substitute(f, {gx, gy, Poly::gen(r, 2), Poly::gen(r, 3)});
        for (std::size_t N : {1u, 3u, 6u}) {
            std::vector<std::optional<Series>> images(4);
            images[0] = Series::graded(gx, p_only, N), images[1] = Series::graded(gy, p_only, N);
            CHECK(compose(f, images, N) == Series::graded(substituted, p_only, N));
        }
    }
}
