#include "series/compile.hpp"
#include "series/poly.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>

using namespace pgi;

namespace {

RingPtr xyz() {
    return make_ring({"x", "y", "z"});
}

// A random polynomial with small rational coefficients (fixed seed: reproducible).
Poly random_poly(const RingPtr& r, std::mt19937& gen, int terms, int max_exp) {
    std::uniform_int_distribution<long> coeff(-9, 9);
    std::uniform_int_distribution<unsigned long> den(1, 5);
    std::uniform_int_distribution<unsigned long> ex(0, static_cast<unsigned long>(max_exp));
    Poly f(r);
    for (int t = 0; t < terms; ++t) {
        Poly m = Poly::constant(r, Rational(coeff(gen), den(gen)));
        for (std::size_t v = 0; v < r->size(); ++v) m = m * pow(Poly::gen(r, v), ex(gen));
        f += m;
    }
    return f;
}

}  // namespace

TEST_CASE("poly: parse and print round-trip with the ring's names") {
    auto r = xyz();
    Poly f = Poly::parse(r, "x*y - 1/2*z^2 + 3");
    CHECK(f.to_string() == "x*y - 1/2*z^2 + 3");
    CHECK(Poly::parse(r, f.to_string()) == f);
    CHECK(Poly::parse(r, "(x + y)^2/6") == Poly::parse(r, "1/6*x^2 + 1/3*x*y + 1/6*y^2"));
    CHECK(Poly::parse(r, "x/(1+1)") == Poly::parse(r, "1/2*x"));
}

TEST_CASE("poly: a name that prefixes another is read whole (x1 versus x10)") {
    auto r = make_ring({"x1", "x10"});
    Poly f = Poly::parse(r, "x10 + 2*x1");
    CHECK(f == Poly::gen(r, 1) + Rational(2) * Poly::gen(r, 0));
}

TEST_CASE("poly: malformed polynomials get a message naming the problem") {
    auto r = xyz();
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x + w"), "malformed polynomial 'x + w': unknown variable 'w' at position 5",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "(x + y"),
                         "malformed polynomial '(x + y': unbalanced parentheses: '(' at position 1 not closed",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x)"),
                         "malformed polynomial 'x)': unbalanced parentheses: ')' without '(' at position 2",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "1/0"), "malformed polynomial '1/0': division by zero at position 3",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x/(y - y)"),
                         "malformed polynomial 'x/(y - y)': division by zero at position 3", ParseError);
    CHECK_THROWS_WITH_AS(
        Poly::parse(r, "x/y"),
        "malformed polynomial 'x/y': division by the variable 'y' at position 3 (only constants may divide)",
        ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x/(x+1)"),
                         "malformed polynomial 'x/(x+1)': division by the non-constant 'x + 1' at position 3",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x^100000"),
                         "malformed polynomial 'x^100000': exponent 100000 exceeds the limit 1000 (at position 3)",
                         ParseError);
    // the degree, however the factors are written: products and powers of polynomials, not only of a variable
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x^1000*x^1000"),
                         "malformed polynomial 'x^1000*x^1000': a product of degree 2000 exceeds the degree limit 1000 "
                         "(at position 7)",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "(x*y)^600"),
                         "malformed polynomial '(x*y)^600': a power of degree 1200 exceeds the degree limit 1000 "
                         "(at position 6)",
                         ParseError);
    CHECK(Poly::parse(r, "x^500*y^500").total_degree() == 1000);
    CHECK(Poly::parse(r, "(x*y)^500").total_degree() == 1000);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "1.5.2*x"),
                         "malformed polynomial '1.5.2*x': unexpected character '.' at position 4", ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x +"),
                         "malformed polynomial 'x +': syntax error at the end: expected a number, a variable or '('",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x y"),
                         "malformed polynomial 'x y': syntax error at position 3: expected an operator", ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "  "), "malformed polynomial '  ': empty", ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "x^-1"), ParseError);
}

TEST_CASE("poly: decimal coefficients are read as exact rationals") {
    auto r = xyz();
    const Poly x = Poly::gen(r, 0), y = Poly::gen(r, 1);
    const auto c = [&](long num, unsigned long den) { return Poly::constant(r, Rational(num, den)); };
    CHECK(Poly::parse(r, "0.05*x") == c(1, 20) * x);
    CHECK(Poly::parse(r, "1.5e-3*x^2") == c(3, 2000) * pow(x, 2));
    CHECK(Poly::parse(r, "0.5*x^2 - 2.5E+2*y + .25") == c(1, 2) * pow(x, 2) - c(250, 1) * y + c(1, 4));
    CHECK(Poly::parse(r, "0.1 + 0.2") == c(3, 10));  // exact: no rounding through double
    CHECK(Poly::parse(r, "3.") == c(3, 1));
    CHECK(Poly::parse(r, "x/0.5") == c(2, 1) * x);
    CHECK(Poly::parse(r, "(1e2*x)^2") == c(10000, 1) * pow(x, 2));
    CHECK(Poly::parse(r, "2e-0") == c(2, 1));
    // the exponent bound is on |e|, written with any number of leading zeros
    CHECK(Poly::parse(r, "1e0000400*x") == Poly::constant(r, Rational::parse("1e400")) * x);
}

TEST_CASE("poly: hostile decimals are refused quickly with the literal and its position") {
    auto r = xyz();
    const Poly x = Poly::gen(r, 0);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x + 1e999999"),
                         "malformed polynomial 'x + 1e999999': '1e999999' is not a number (exponent out of range: "
                         "at most 400 in absolute value) at position 5",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "1e-401*x"),
                         "malformed polynomial '1e-401*x': '1e-401' is not a number (exponent out of range: at most "
                         "400 in absolute value) at position 1",
                         ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "1e99999999999999999999999*x"), ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "1e" + std::string(100000, '9')), ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "x^2.5"),
                         "malformed polynomial 'x^2.5': '^' must be followed by a non-negative integer at position 3, "
                         "not a decimal",
                         ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "x^2e1"), ParseError);
    // an 'e' without digits is no exponent: "2e" is 2 followed by a name, "2ex" likewise
    CHECK_THROWS_WITH_AS(Poly::parse(r, "2e"),
                         "malformed polynomial '2e': syntax error at position 2: expected an operator", ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "2e+"), ParseError);
    CHECK_THROWS_AS(Poly::parse(r, ". * x"), ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "1..5"), ParseError);
    // many digits are read in time and memory proportional to the text
    const std::string long_decimal = "0." + std::string(200000, '0') + "1";
    CHECK(Poly::parse(r, long_decimal + "*x") == Poly::constant(r, Rational::parse(long_decimal)) * x);
}

TEST_CASE("poly: regression (fuzzer timeout): nested and chained powers are bounded like single ones") {
    auto r = xyz();
    CHECK_THROWS_WITH_AS(Poly::parse(r, "77^777^7^777^777"),
                         "malformed polynomial '77^777^7^777^777': chained exponents at position 7: write (a^b)^c",
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, "((x+y)^100)^100"),
                         "malformed polynomial '((x+y)^100)^100': exponent 100 inside groups raised to the power 100 "
                         "exceeds the limit 1000 (at position 13)",
                         ParseError);
    CHECK_THROWS_AS(Poly::parse(r, "(((x)^10)^10)^11"), ParseError);
    CHECK(Poly::parse(r, "((x)^10)^10") == pow(Poly::gen(r, 0), 100));
    CHECK(Poly::parse(r, "(x + 1)^2 * (y - 1)^3") == pow(Poly::parse(r, "x + 1"), 2) * pow(Poly::parse(r, "y - 1"), 3));
}

TEST_CASE("poly: derivative obeys the product rule on random inputs (FLINT t-derivative style)") {
    auto r = xyz();
    std::mt19937 gen(20261122);
    for (int trial = 0; trial < 20; ++trial) {
        Poly f = random_poly(r, gen, 6, 4), g = random_poly(r, gen, 6, 4);
        for (std::size_t v = 0; v < 3; ++v) {
            CAPTURE(trial);
            CHECK(derivative(f * g, v) == derivative(f, v) * g + f * derivative(g, v));
        }
    }
}

TEST_CASE("poly: sum over one denominator equals adding one by one, in canonical form (zero, one, many pieces)") {
    auto r = xyz();
    std::mt19937 gen(20261124);
    CHECK(sum({}, r).is_zero());
    for (int trial = 0; trial < 20; ++trial) {
        CAPTURE(trial);
        std::vector<Poly> pieces;
        Poly expected(r);
        for (int i = 0; i < 1 + trial % 9; ++i) {
            // contents with different denominators and signs, some pieces cancelling others
            Poly p = (i % 4 == 3)
                         ? -pieces.back()
                         : random_poly(r, gen, 1 + i % 5, 3) * Poly::constant(r, Rational(i % 2 ? -7 : 3, 2 + i));
            expected += p;
            pieces.push_back(std::move(p));
        }
        pieces.push_back(Poly(r));  // a zero piece is skipped
        const Poly s = sum(pieces, r);
        CHECK(s == expected);  // == compares FLINT's canonical content: sum must have reduced it
        CHECK(s.to_string() == expected.to_string());
    }
}

TEST_CASE("poly: substitution is a ring morphism") {
    auto r = xyz();
    std::mt19937 gen(7);
    std::vector<Poly> images{random_poly(r, gen, 3, 2), random_poly(r, gen, 3, 2), random_poly(r, gen, 3, 2)};
    for (int trial = 0; trial < 10; ++trial) {
        Poly f = random_poly(r, gen, 4, 3), g = random_poly(r, gen, 4, 3);
        CHECK(substitute(f * g, images) == substitute(f, images) * substitute(g, images));
        CHECK(substitute(f - g, images) == substitute(f, images) - substitute(g, images));
    }
    CHECK(substitute(Poly::parse(r, "x*y + z"), {Poly::parse(r, "y"), Poly::parse(r, "x"), Poly::parse(r, "2")}) ==
          Poly::parse(r, "x*y + 2"));
}

TEST_CASE("poly: homogeneous parts in a subset of variables add up to the polynomial") {
    auto r = xyz();
    VarMask yz{false, true, true};
    Poly f = Poly::parse(r, "x^5 + x*y + y*z^2 - 3*z + x^2*y^2*z");
    CHECK(homogeneous_part(f, yz, 0) == Poly::parse(r, "x^5"));
    CHECK(homogeneous_part(f, yz, 1) == Poly::parse(r, "x*y - 3*z"));
    CHECK(homogeneous_part(f, yz, 3) == Poly::parse(r, "y*z^2 + x^2*y^2*z"));
    CHECK(truncate(f, yz, 1) == Poly::parse(r, "x^5 + x*y - 3*z"));
    CHECK(masked_degree(f, yz) == 3);
    Poly sum(r);
    for (unsigned long m = 0; m <= 3; ++m) sum += homogeneous_part(f, yz, m);
    CHECK(sum == f);
}

TEST_CASE("poly: mixing rings is refused") {
    auto r = xyz(), s = xyz();
    CHECK_THROWS_WITH_AS(Poly::gen(r, 0) * Poly::gen(s, 0), "pgi::mul: operands belong to different rings",
                         std::invalid_argument);
}

TEST_CASE("poly: value semantics (copies are deep, moves leave a valid empty poly)") {
    auto r = xyz();
    Poly f = Poly::parse(r, "x + y");
    Poly g = f;
    g += Poly::gen(r, 2);
    CHECK(f == Poly::parse(r, "x + y"));
    Poly h = std::move(g);
    CHECK(h == Poly::parse(r, "x + y + z"));
    CHECK(g.is_zero());  // NOLINT(bugprone-use-after-move): moved-from is the zero poly by contract
}

TEST_CASE("poly: rename_variables moves a polynomial between rings") {
    auto small = make_ring({"a", "b"});
    auto big = make_ring({"u", "a", "v", "b"});
    CHECK(rename_variables(Poly::parse(small, "a^2*b - 1/3"), big, {1, 3}) == Poly::parse(big, "a^2*b - 1/3"));
}

namespace {

// The exact value of f at a point of doubles, and the sum of the terms' absolute values.
std::pair<Rational, double> exact_value(const Poly& f, const std::vector<double>& point) {
    Rational sum;
    double size = 0;
    for (std::size_t i = 0; i < f.length(); ++i) {
        Rational term = f.term_coeff(i);
        const auto e = f.term_exponents(i);
        for (std::size_t v = 0; v < e.size(); ++v)
            for (unsigned long k = 0; k < e[v]; ++k) term = term * Rational::from_double(point[v]);
        size += std::abs(term.to_double());
        sum = sum + term;
    }
    return {sum, size};
}

// |y - exact| for a long double y, exactly: y = hi + lo with hi, lo doubles.
double error_of(long double y, const Rational& exact) {
    const double hi = static_cast<double>(y), lo = static_cast<double>(y - hi);
    return std::abs((Rational::from_double(hi) + Rational::from_double(lo) - exact).to_double());
}

}  // namespace

TEST_CASE("compile: CompiledMap agrees with exact evaluation, in double and in long double") {
    // dyadic coefficients and inputs, so the only errors are the evaluators' own rounding
    auto r = xyz();
    std::mt19937 gen(7);
    std::uniform_int_distribution<long> coeff(-99, 99);
    std::uniform_real_distribution<double> input(-1.5, 1.5);
    std::uniform_int_distribution<unsigned long> ex(0, 4);
    double total_double = 0, total_long = 0;
    for (int trial = 0; trial < 20; ++trial) {
        std::vector<Poly> outputs;
        for (int o = 0; o < 3; ++o) {
            Poly f(r);
            for (int t = 0; t < 12; ++t) {
                Poly m = Poly::constant(r, Rational(coeff(gen), 1L << (t % 5)));
                for (std::size_t v = 0; v < 3; ++v) m = m * pow(Poly::gen(r, v), ex(gen));
                f += m;
            }
            outputs.push_back(f);
        }
        const CompiledMap map = CompiledMap::build(outputs, {0, 1, 2});
        const std::vector<double> x{input(gen), input(gen), input(gen)};
        const std::vector<long double> xl(x.begin(), x.end());
        std::vector<double> y(3);
        std::vector<long double> yl(3), scratch;
        map.eval(x.data(), y.data());
        map.eval(xl.data(), yl.data(), scratch);
        for (std::size_t o = 0; o < 3; ++o) {
            const auto [exact, size] = exact_value(outputs[o], x);
            // each term has at most 12 + 12 roundings (monomial products, coefficient, sum): gamma_24
            const double err_double = error_of(static_cast<long double>(y[o]), exact),
                         err_long = error_of(yl[o], exact);
            CHECK(err_double <= 24 * 0x1p-53 * size);
            CHECK(err_long <= 24 * 0x1p-64 * size);
            total_double += err_double;
            total_long += err_long;
        }
    }
    // a long double path that secretly rounded to double would not be 100 times better overall
    REQUIRE(total_double > 0);
    CHECK(total_long * 100 < total_double);
}

// issue 11.4
TEST_CASE("a power is estimated before it is expanded and refused with its position") {
    auto r = make_ring({"x1", "x2", "x3", "x4", "x5", "x6"}, 1000);
    // (x1+...+x6)^10 has binomial(15, 5) = 3003 terms: above 1000, refused before FLINT expands it
    CHECK_THROWS_WITH_AS(
        Poly::parse(r, "(x1+x2+x3+x4+x5+x6)^10"),
        "polynomial '(x1+x2+x3+x4+x5+x6)^10': expanding the '^' at position 20: the power 10 of a 6-term "
        "polynomial could reach 3003 terms, above the limit of 1000 (raise it with --max-terms or max_terms)",
        ResourceLimitError);
    CHECK(Poly::parse(r, "(x1+x2+x3+x4+x5+x6)^5").length() == 252);  // binomial(10, 5): within the budget
    // the same for a product: 126 * 126 terms, at most binomial(14, 6) = 3003 monomials of degree 8
    CHECK_THROWS_WITH_AS(
        Poly::parse(r, "(x1+x2+x3+x4+x5+x6)^4 * (x1+x2+x3+x4+x5+x6)^4"),
        doctest::Contains("expanding the '*' at position 23: a product of a 126-term and a 126-term polynomial "
                          "could reach 3003 terms"),
        ResourceLimitError);
}

// issue 11.4
TEST_CASE("nesting is bounded (parentheses, signs, divisions), with the position") {
    auto r = xyz();
    auto nested = [](const std::string& open, const std::string& inner, const std::string& close, int n) {
        std::string s;
        for (int i = 0; i < n; ++i) s += open;
        s += inner;
        for (int i = 0; i < n; ++i) s += close;
        return s;
    };
    const std::string deep =
        "nesting deeper than " + std::to_string(max_parse_depth) + " (parentheses and signs) at position ";
    CHECK_THROWS_WITH_AS(Poly::parse(r, nested("1/(", "x", ")", 100000)), doctest::Contains((deep + "603").c_str()),
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, nested("(", "x", ")", 10000)), doctest::Contains((deep + "201").c_str()),
                         ParseError);
    CHECK_THROWS_WITH_AS(Poly::parse(r, nested("-", "x", "", 100000)), doctest::Contains((deep + "201").c_str()),
                         ParseError);
    // the message quotes only the start of a long text
    CHECK_THROWS_WITH_AS(Poly::parse(r, nested("(", "x", ")", 10000)),
                         doctest::Contains(("malformed polynomial '" + std::string(60, '(') + "...'").c_str()),
                         ParseError);
    // depth up to the bound is fine, and means what it says
    CHECK(Poly::parse(r, nested("1/(", "2", ")", 60)) == Poly::constant(r, Rational(2)));  // 1/(1/2) = 2, 30 times
    CHECK(Poly::parse(r, nested("-", "x", "", 199)) == -Poly::gen(r, 0));
    CHECK(Poly::parse(r, nested("(", "x+y", ")", 199)) == Poly::gen(r, 0) + Poly::gen(r, 1));
}

TEST_CASE("poly: the reader agrees with FLINT's own parser on random expressions") {
    auto r = xyz();
    std::mt19937 gen(11);
    // expression := term (+|-) term ...; term := factor * factor ...; factor := atom [^e] | (expression)[^e]
    std::function<std::string(int)> expression = [&](int depth) {
        auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(gen); };
        auto atom = [&]() -> std::string {
            switch (pick(depth > 0 ? 4 : 3)) {
                case 0:
                    return std::to_string(pick(20));
                case 1:
                    return std::string(1, "xyz"[pick(3)]);
                case 2:
                    return std::to_string(pick(9) + 1) + "/" + std::to_string(pick(9) + 1);
                default:
                    return "(" + expression(depth - 1) + ")";
            }
        };
        std::string s = pick(4) == 0 ? "-" : "";
        for (int t = pick(3) + 1; t > 0; --t) {
            for (int f = pick(3) + 1; f > 0; --f) {
                s += atom();
                if (pick(3) == 0) s += "^" + std::to_string(pick(4));
                if (f > 1) s += pick(2) ? "*" : " * ";
            }
            if (t > 1) s += pick(2) ? " + " : "-";
        }
        return s;
    };
    std::vector<const char*> names{"x", "y", "z"};
    for (int trial = 0; trial < 300; ++trial) {
        const std::string text = expression(2);
        CAPTURE(text);
        Poly theirs(r);
        REQUIRE(fmpq_mpoly_set_str_pretty(theirs.get_mut(), text.c_str(), names.data(), theirs.ctx()) == 0);
        CHECK(Poly::parse(r, text) == theirs);
    }
}

TEST_CASE("compile: every coefficient is the correctly rounded double of its exact rational, at any size") {
    // f = A x + B y shares one content between A and B; at (1, 0) and (0, 1) the map returns each coefficient
    // as compiled. Numerators and denominators of 1 to 100 bits cover both sides of 2^53.
    auto r = xyz();
    std::mt19937_64 gen(16);
    const auto integer = [&](unsigned bits) {
        Rational z(0);
        for (unsigned b = 0; b < bits; b += 20)
            z = z * Rational(1L << std::min(20u, bits - b)) +
                Rational(static_cast<long>(gen() >> (64 - std::min(20u, bits - b))));
        return z + Rational(1);
    };
    std::uniform_int_distribution<unsigned> bits(1, 100);
    for (int trial = 0; trial < 400; ++trial) {
        const Rational A = (trial % 2 ? Rational(-1) : Rational(1)) * integer(bits(gen)) / integer(bits(gen));
        const Rational B = integer(bits(gen)) / integer(bits(gen));
        const Poly f = Poly::constant(r, A) * Poly::gen(r, 0) + Poly::constant(r, B) * Poly::gen(r, 1);
        const CompiledMap map = CompiledMap::build({f}, {0, 1});
        double out = 0;
        const double at_x[2] = {1, 0}, at_y[2] = {0, 1};
        map.eval(at_x, &out);
        CHECK(out == A.to_double());
        map.eval(at_y, &out);
        CHECK(out == B.to_double());
    }
}

TEST_CASE("compile: many inputs and high degrees (monomials ordered without the packed key) evaluate exactly") {
    // 10 inputs and degree 70 do not fit one word per monomial; powers of two keep every value exact
    std::vector<std::string> names;
    for (int v = 0; v < 10; ++v) names.push_back("x" + std::to_string(v));
    auto r = make_ring(names);
    // each output's terms of near magnitudes, so its sum is exact in any order
    const std::vector<Poly> fs{Poly::parse(r, "x0^70"), Poly::parse(r, "3*x1*x2 - x9^2*x0 + 1/4*x3^5*x4^6*x5 + 7"),
                               Poly::parse(r, "x9^3 - x8*x7*x6"), Poly::parse(r, "x0^69*x1")};
    std::vector<std::size_t> inputs(10);
    for (std::size_t v = 0; v < 10; ++v) inputs[v] = 9 - v;  // reversed: the input order is not the ring's
    const CompiledMap map = CompiledMap::build(fs, inputs);
    const std::vector<double> point{0.5, -2, 4, 0.25, -0.5, 2, 8, -1, 0.125, 1};  // ring order
    std::vector<double> in(10), out(fs.size());
    for (std::size_t v = 0; v < 10; ++v) in[v] = point[inputs[v]];
    map.eval(in.data(), out.data());
    for (std::size_t o = 0; o < fs.size(); ++o) CHECK(out[o] == evaluate(fs[o], point));
    CHECK(out[0] == std::ldexp(1.0, -70));
}
