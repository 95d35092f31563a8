#include "series/rational.hpp"

#include "series/detail/decimal.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <string>

using namespace pgi;

TEST_CASE("rational: parses integers, fractions and decimals exactly") {
    CHECK(Rational::parse("3") == Rational(3));
    CHECK(Rational::parse(" -1/100 ") == Rational(-1, 100));
    CHECK(Rational::parse("0.1") == Rational(1, 10));
    CHECK(Rational::parse("1.25e-2") == Rational(1, 80));
    CHECK(Rational::parse("-2E3") == Rational(-2000));
    CHECK(Rational::parse("1/0.5") == Rational(2));
}

TEST_CASE("rational: malformed numbers are refused with the text in the message") {
    CHECK_THROWS_WITH_AS(Rational::parse("1/0"), "'1/0' is not a number (zero denominator)", std::invalid_argument);
    CHECK_THROWS_WITH_AS(Rational::parse("abc"),
                         "'abc' is not a number (expected an integer, a decimal or a fraction a/b)",
                         std::invalid_argument);
    CHECK_THROWS_AS(Rational::parse(""), std::invalid_argument);
    CHECK_THROWS_AS(Rational::parse("1..2"), std::invalid_argument);
    CHECK_THROWS_AS(Rational::parse("1e99999999"), std::invalid_argument);
    CHECK_THROWS_AS(Rational::parse("nan"), std::invalid_argument);
}

TEST_CASE("rational: a decimal's exponent is bounded by 400 in absolute value") {
    CHECK(Rational::parse("1e400") == Rational::parse("1" + std::string(400, '0')));
    CHECK(Rational::parse("-2.5e-0400") == Rational(-25) / (Rational(10) * Rational::parse("1e400")));
    CHECK_THROWS_WITH_AS(Rational::parse("1e401"),
                         "'1e401' is not a number (exponent out of range: at most 400 in absolute value)",
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(Rational::parse("1e999999"),
                         "'1e999999' is not a number (exponent out of range: at most 400 in absolute value)",
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(Rational::parse("1e"), "'1e' is not a number (malformed exponent)", std::invalid_argument);
    CHECK_THROWS_AS(Rational::parse("1e+-2"), std::invalid_argument);
}

TEST_CASE("rational: the extent of a decimal literal inside a longer text") {
    CHECK(decimal_literal_length("0.05*x") == 4);
    CHECK(decimal_literal_length("1.5e-3*x") == 6);
    CHECK(decimal_literal_length("2E+10)") == 5);
    CHECK(decimal_literal_length(".5") == 2);
    CHECK(decimal_literal_length("3.x") == 2);
    CHECK(decimal_literal_length("2ex") == 1);
    CHECK(decimal_literal_length("2e+") == 1);
    CHECK(decimal_literal_length(".") == 0);
    CHECK(decimal_literal_length("x1") == 0);
    CHECK(decimal_literal_length("") == 0);
}

TEST_CASE("rational: conversion to double is correctly rounded") {
    CHECK(Rational(1, 10).to_double() == 0.1);
    CHECK(Rational(1, 3).to_double() == 1.0 / 3.0);
    CHECK(Rational(2, 3).to_double() == 2.0 / 3.0);
    // 2^53 + 1 is halfway between two doubles: ties to even gives 2^53
    Rational big = Rational::parse("9007199254740993");
    CHECK(big.to_double() == 9007199254740992.0);
    for (double v : {0.1, -3.75, 1e-300, 6.02214076e23, std::ldexp(1.0, -1074)}) {
        CAPTURE(v);
        CHECK(Rational::from_double(v).to_double() == v);
    }
    CHECK(Rational::from_double(0.5) == Rational(1, 2));
    CHECK_THROWS_AS(Rational::from_double(std::nan("")), std::invalid_argument);
}

TEST_CASE("rational: Bernoulli numbers come from FLINT with B_1 = -1/2") {
    CHECK(bernoulli(0) == Rational(1));
    CHECK(bernoulli(1) == Rational(-1, 2));
    CHECK(bernoulli(2) == Rational(1, 6));
    CHECK(bernoulli(3) == Rational(0));
    CHECK(bernoulli(4) == Rational(-1, 30));
    CHECK(bernoulli(12) == Rational(-691, 2730));
    CHECK(inverse_factorial(5) == Rational(1, 120));
}
