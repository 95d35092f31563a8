// CompiledMap::eval_batch: m points at once in structure-of-arrays layout, each lane bit for bit eval()'s.
#include "series/compile.hpp"
#include "series/poly.hpp"
#include "poisson/realisation_eval.hpp"  // absolute_coefficients

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>

using namespace pgi;

namespace {

// Random polynomials in k inputs (one of the ring's variables unused, to check the input order), with
// outputs of every length class: empty, a constant, fewer than four terms, and many (the four partial sums
// and their remainder).
std::vector<Poly> random_outputs(const RingPtr& r, std::size_t k, std::mt19937& gen) {
    std::uniform_int_distribution<long> coeff(-999, 999);
    std::uniform_int_distribution<unsigned long> ex(0, 3);
    std::vector<Poly> outputs{Poly(r), Poly::constant(r, Rational(-7, 3))};
    for (int terms : {1, 3, 5, 11, 30}) {
        Poly f(r);
        for (int t = 0; t < terms; ++t) {
            Poly m = Poly::constant(
                r, Rational(coeff(gen),
                            static_cast<unsigned long>(1 + std::abs(coeff(gen)))));  // not dyadic: rounded coefficients
            for (std::size_t v = 0; v < k; ++v) m = m * pow(Poly::gen(r, v + 1), ex(gen));
            f += m;
        }
        outputs.push_back(f);
    }
    return outputs;
}

std::uint64_t bits(double v) {
    return std::bit_cast<std::uint64_t>(v);
}

// f (40 random terms in x, y, z), a lone output on other monomials, and seven outputs on f's monomials (other
// coefficients, and a constant): two groups of four and a lone output.
std::vector<Poly> grouped_outputs(const RingPtr& r, std::mt19937& gen) {
    std::uniform_int_distribution<long> coeff(-9, 9);
    std::uniform_int_distribution<unsigned long> ex(0, 3);
    Poly f(r);
    for (int t = 0; t < 40; ++t) {
        Poly m = Poly::constant(r, Rational(coeff(gen), 4));
        for (std::size_t v = 0; v < 3; ++v) m = m * pow(Poly::gen(r, v), ex(gen));
        f += m;
    }
    std::vector<Poly> outputs{f, pow(Poly::gen(r, 0), 9) + pow(Poly::gen(r, 1), 11)};
    for (long c : {2, -3, 5, 7, -11, 13, -17})
        outputs.push_back(Poly::constant(r, Rational(c, 8)) * f + Poly::constant(r, Rational(c)));
    return outputs;
}

}  // namespace

TEST_CASE("compile: eval_batch gives every lane eval()'s bits, for any number of points") {
    const std::size_t k = 4;
    const auto r = make_ring({"unused", "a", "b", "c", "d"});
    std::mt19937 gen(11);
    std::uniform_real_distribution<double> input(-2.0, 2.0);
    std::size_t compared = 0, differing_inputs = 0;
    for (int trial = 0; trial < 6; ++trial) {
        std::vector<double> scratch;  // shared by every m: resized once, then reused
        const std::vector<Poly> outputs = random_outputs(r, k, gen);
        const CompiledMap map = CompiledMap::build(outputs, {4, 2, 1, 3});  // inputs in an order of their own
        const std::size_t O = map.num_outputs();
        for (std::size_t m : {1, 2, 3, 4, 7, 8, 9, 13, 16, 31, 100}) {
            std::vector<double> in(k * m), out(O * m, -1.0), x(k), y(O);
            for (auto& v : in) v = input(gen);
            if (m > 2) in[1] = -0.0, in[m + 2] = 0.0;  // signed zeros stay what eval makes of them
            map.eval_batch(in.data(), out.data(), m, scratch);
            for (std::size_t j = 0; j < m; ++j) {
                for (std::size_t v = 0; v < k; ++v) x[v] = in[v * m + j];
                map.eval(x.data(), y.data());
                for (std::size_t o = 0; o < O; ++o) {
                    CAPTURE(trial);
                    CAPTURE(m);
                    CAPTURE(j);
                    CAPTURE(o);
                    CHECK(bits(out[o * m + j]) == bits(y[o]));
                    ++compared;
                }
                if (j > 0 && y.back() != out[(O - 1) * m]) ++differing_inputs;
            }
        }
        CHECK(scratch.size() == (map.num_monomials() + k + O) * CompiledMap::batch_lanes);  // bounded, whatever m
    }
    CHECK(compared > 1000);
    CHECK(differing_inputs > 100);  // the lanes really hold different points (not one value broadcast)
}

TEST_CASE("compile: eval_batch of no points writes nothing") {
    const auto r = make_ring({"x"});
    const CompiledMap map = CompiledMap::build({Poly::gen(r, 0) + Poly::constant(r, Rational(1, 1))}, {0});
    std::vector<double> scratch;
    double out = 42;
    map.eval_batch(nullptr, &out, 0, scratch);
    CHECK(out == 42);
}

TEST_CASE("compile: monomials are made as products of two (an addition chain), not one input at a time") {
    const auto r = make_ring({"x", "y", "z"});
    const auto f = [&](const char* s) { return Poly::parse(r, s); };
    // x^16, y^16 by squaring (4 products each), x^16 y^16 as their product: 9 products; the inputs one at a time
    // take 15 + 15 + 16 = 46
    const CompiledMap powers = CompiledMap::build({f("x^16"), f("y^16"), f("x^16*y^16")}, {0, 1, 2});
    CHECK(powers.num_monomials() == 1 + 3 + 9);
    // a polynomial in squares (the rigid body's S_dt): every monomial of degree 2j is a product of two of
    // lower degree, one product each (9 of them); one input at a time would add intermediate ones (x y^2, ...)
    const CompiledMap squares = CompiledMap::build(
        {f("x^2 + y^2 + z^2 + x^2*y^2 + y^2*z^2 + x^2*z^2 + x^4*y^2 + x^2*y^2*z^2 + x^4*z^4")}, {0, 1, 2});
    CHECK(squares.num_monomials() == 1 + 3 + 9);
    const double in[3] = {0.5, -2, 4};
    double out = 0;
    squares.eval(in, &out);
    CHECK(out == 0.25 + 4 + 16 + 1 + 64 + 4 + 0.25 + 16 + 0.0625 * 256);  // powers of two: exact in any order
}

TEST_CASE(
    "compile: outputs sharing their monomials are evaluated four at a time, with eval_batch's bits and exact values") {
    const auto r = make_ring({"x", "y", "z"});
    std::mt19937 gen(5);
    const std::vector<Poly> outputs = grouped_outputs(r, gen);
    const Poly& f = outputs[0];
    const CompiledMap map = CompiledMap::build(outputs, {0, 1, 2});
    std::size_t one_by_one = 0;
    for (const auto& o : outputs) one_by_one += o.length();
    CHECK(map.num_terms() * 3 < one_by_one);  // grouped: each shared monomial read once per group of four
    // dyadic inputs: every term and partial sum is exact (coefficients k/32, powers of 1/2 and 2), so any order gives
    // the exact value
    const std::vector<double> point{0.5, -2, 0.25};
    std::vector<double> y(outputs.size());
    map.eval(point.data(), y.data());
    for (std::size_t o = 0; o < outputs.size(); ++o) CHECK(y[o] == evaluate(outputs[o], point));
    // a monomial only one output of a group reads overflows: that output is infinite, the others stay finite (the
    // group's zero coefficients add nothing, not 0 inf = NaN), and eval_batch agrees bit for bit
    {
        std::vector<Poly> g{f + pow(Poly::gen(r, 0), 5)};
        for (long c : {2, 3, 5}) g.push_back(Poly::constant(r, Rational(c)) * f);
        const CompiledMap overflow = CompiledMap::build(g, {0, 1, 2});
        REQUIRE(overflow.num_terms() < f.length() + 1 + 3 * f.length());  // grouped
        const double huge[3] = {1e70, 0.5, 0.5};  // x^5 = inf, f's monomials (x^3 at most) finite
        std::vector<double> v(4), scratch_overflow;
        overflow.eval(huge, v.data());
        CHECK(std::isinf(v[0]));
        for (std::size_t o = 1; o < 4; ++o) CHECK(std::isfinite(v[o]));
        const std::size_t m8 = CompiledMap::batch_lanes;  // a whole block: the lanes' own code, not eval's
        std::vector<double> in8(3 * m8), out8(4 * m8);
        for (std::size_t v3 = 0; v3 < 3; ++v3) std::fill_n(in8.begin() + std::ptrdiff_t(v3 * m8), m8, huge[v3]);
        overflow.eval_batch(in8.data(), out8.data(), m8, scratch_overflow);
        for (std::size_t o = 0; o < 4; ++o) CHECK(bits(out8[o * m8 + m8 - 1]) == bits(v[o]));
    }
    // each lane of a batch is eval()'s, bit for bit
    std::uniform_real_distribution<double> input(-1.5, 1.5);
    const std::size_t m = 21;
    std::vector<double> in(3 * m), out(outputs.size() * m), scratch;
    for (auto& v : in) v = input(gen);
    map.eval_batch(in.data(), out.data(), m, scratch);
    for (std::size_t j = 0; j < m; ++j) {
        const double x[3] = {in[j], in[m + j], in[2 * m + j]};
        map.eval(x, y.data());
        for (std::size_t o = 0; o < outputs.size(); ++o) CHECK(bits(out[o * m + j]) == bits(y[o]));
    }
}

TEST_CASE(
    "compile: groups summed as one AVX2 vector of four give the SSE2 pairs' bits; automatic takes fours where they "
    "pay") {
    const auto r = make_ring({"x", "y", "z"}), r4 = make_ring({"unused", "a", "b", "c"});
    std::mt19937 gen(8);
    CompiledMap grouped = CompiledMap::build(grouped_outputs(r, gen), {0, 1, 2});
    CompiledMap rows = CompiledMap::build(random_outputs(r4, 3, gen), {3, 1, 2});
    CHECK(grouped.fours_pay());     // two full groups over most of the map's terms
    CHECK_FALSE(rows.fours_pay());  // no groups: nothing saved
    CHECK(grouped.groups_in_fours() == (processor_has_avx2() && grouped.fours_pay()));
    CHECK_FALSE(rows.groups_in_fours());
    if (!processor_has_avx2()) {
        CHECK_THROWS_AS(grouped.set_group_vectors(GroupVectors::avx2), std::invalid_argument);
        MESSAGE("this processor has no AVX2: the fours are not run");
        return;
    }
    std::uniform_real_distribution<double> input(-2.0, 2.0);
    const std::size_t O = grouped.num_outputs();
    std::vector<double> pairs(O), fours(O);
    for (int point = 0; point < 300; ++point) {
        double x[3] = {input(gen), input(gen), input(gen)};
        if (point == 1) x[0] = -0.0, x[1] = 0.0;  // signed zeros
        if (point == 2) x[0] = 1e70;              // infinite monomials beside finite ones
        if (point == 3) x[2] = std::numeric_limits<double>::quiet_NaN();
        grouped.set_group_vectors(GroupVectors::sse2);
        REQUIRE_FALSE(grouped.groups_in_fours());
        grouped.eval(x, pairs.data());
        grouped.set_group_vectors(GroupVectors::avx2);
        REQUIRE(grouped.groups_in_fours());
        grouped.eval(x, fours.data());
        for (std::size_t o = 0; o < O; ++o) {
            CAPTURE(point);
            CAPTURE(o);
            CHECK(bits(fours[o]) == bits(pairs[o]));
        }
    }
}

namespace {

// Outputs in x, y, z whose coefficients are polynomials in p, q: the grouped outputs (groups of four on shared
// monomials) times p - 2 q^2 / 3 + 1/5, plus the next one times q, and a term in p alone.
std::vector<Poly> parameterised_outputs(const RingPtr& r, std::mt19937& gen) {
    const std::vector<Poly> g = grouped_outputs(r, gen);
    const Poly p = Poly::gen(r, 3), q = Poly::gen(r, 4);
    const Poly a = p - Poly::constant(r, Rational(2, 3)) * q * q + Poly::constant(r, Rational(1, 5));
    std::vector<Poly> outputs;
    for (std::size_t i = 0; i < g.size(); ++i) outputs.push_back(g[i] * a + g[(i + 1) % g.size()] * q + p * p * p);
    return outputs;
}

// out[o] against the whole map's at the same point: within 1e-14 of the sum of its terms' sizes (the sizes' map at
// |in|), the round-off of two sums of those terms in a different order.
void check_close(const std::vector<double>& got, const std::vector<double>& want, const std::vector<double>& size) {
    for (std::size_t o = 0; o < got.size(); ++o) {
        CAPTURE(o);
        CHECK(std::abs(got[o] - want[o]) <= 1e-14 * size[o]);
    }
}

}  // namespace

TEST_CASE("compile: a map read through its slow inputs' coefficients equals the whole map to round-off") {
    const auto r = make_ring({"x", "y", "z", "p", "q"});
    std::mt19937 gen(7);
    const std::vector<Poly> outputs = parameterised_outputs(r, gen);
    std::vector<Poly> abs_outputs;
    for (const Poly& f : outputs) abs_outputs.push_back(absolute_coefficients(f));
    const std::vector<std::size_t> inputs{0, 1, 2, 3, 4};
    const CompiledMap whole = CompiledMap::build(outputs, inputs), sizes = CompiledMap::build(abs_outputs, inputs);
    const CompiledMap two = CompiledMap::build(outputs, inputs, 2);
    REQUIRE(two.num_slow_inputs() == 2);
    REQUIRE(two.num_outputs() == whole.num_outputs());
    CHECK(two.lane_cache_size(8) > 0);
    CHECK(whole.lane_cache_size(8) == 0);
    // the point of two stages: an evaluation costs what the map with p, q written in costs, far less than the whole
    CHECK(2 * two.num_terms() < whole.num_terms());
    CHECK_THROWS_AS(CompiledMap::build(outputs, inputs, 6), std::invalid_argument);

    const std::size_t O = whole.num_outputs();
    std::uniform_real_distribution<double> coordinate(-1.5, 1.5), parameter(-2.0, 2.0);
    std::vector<double> got(O), want(O), size(O), first(O);
    const auto at = [&](const std::vector<double>& in) {
        std::vector<double> magnitude(in.size());
        for (std::size_t v = 0; v < in.size(); ++v) magnitude[v] = std::abs(in[v]);
        whole.eval(in.data(), want.data());
        sizes.eval(magnitude.data(), size.data());
        two.eval(in.data(), got.data());
    };
    SUBCASE("one point at a time, the parameters changing between evaluations") {
        const std::vector<double> x0{0.3, -1.1, 0.7, 1.25, -0.5};
        at(x0);
        check_close(got, want, size);
        first = got;
        for (int trial = 0; trial < 20; ++trial) {
            std::vector<double> in{coordinate(gen), coordinate(gen), coordinate(gen), parameter(gen), parameter(gen)};
            if (trial % 2) in[3] = x0[3], in[4] = x0[4];  // the same parameters as before at another point, or others
            at(in);
            check_close(got, want, size);
        }
        at(x0);  // back to the first parameters: their coefficients again, the same bits
        for (std::size_t o = 0; o < O; ++o) CHECK(bits(got[o]) == bits(first[o]));
        std::vector<long double> lin(x0.begin(), x0.end()), lout(O), lscratch;
        two.eval(lin.data(), lout.data(), lscratch);
        for (std::size_t o = 0; o < O; ++o) CHECK(std::abs(double(lout[o]) - first[o]) <= 1e-14 * size[o]);
    }
    SUBCASE("a cache kept across a map built anew in the same object holds the new map's coefficients") {
        constexpr std::size_t m = 8;
        std::vector<double> in(5 * m), out(O * m), again(O * m), scratch;
        for (std::size_t v = 0; v < 5; ++v)
            for (std::size_t j = 0; j < m; ++j) in[v * m + j] = v < 3 ? coordinate(gen) : parameter(gen);
        LaneCoefficients kept;
        CompiledMap map = CompiledMap::build(outputs, inputs, 2);
        map.eval_batch(in.data(), out.data(), m, scratch, &kept);
        std::vector<Poly> doubled;
        for (const Poly& f : outputs) doubled.push_back(f + f);
        map = CompiledMap::build(doubled, inputs, 2);  // the same address and parameter values, other coefficients
        map.eval_batch(in.data(), again.data(), m, scratch, &kept);
        for (std::size_t e = 0; e < out.size(); ++e) CHECK(bits(again[e]) == bits(2 * out[e]));  // doubling is exact
    }
    SUBCASE("a coefficient that vanishes at a lane's parameters, times an overflowing monomial: eval's bits") {
        // p x^4 + 2 x^3 + ... shares its monomials with B and 2B (a group); at p = 0 and x = 1e100, eval's group masks
        // p's 0 (not 0 inf = NaN), and so must each lane, beside lanes where it does not vanish
        const auto s = make_ring({"x", "p"});
        const Poly x = Poly::gen(s, 0), p = Poly::gen(s, 1);
        Poly B(s);
        for (unsigned long k = 0; k <= 4; ++k) B += pow(x, k);
        const auto c = [&s](long v) { return Poly::constant(s, Rational(v)); };
        const Poly first_output = p * pow(x, 4) + c(2) * pow(x, 3) + c(3) * pow(x, 2) + c(4) * x + c(5);
        const CompiledMap map = CompiledMap::build({first_output, B, c(2) * B, p * B}, {0, 1}, 1);
        REQUIRE(map.tape().groups > 0);
        constexpr std::size_t m = 11;
        std::vector<double> in(2 * m), out(4 * m), single(4), scratch;
        for (std::size_t j = 0; j < m; ++j) {
            in[j] = j % 3 == 0 ? 1e100 : j % 3 == 1 ? -1e90 : 0.5 + double(j);
            in[m + j] = j % 2 ? 0.0 : 1.5;
        }
        map.eval_batch(in.data(), out.data(), m, scratch);
        std::size_t finite_from_masking = 0;
        for (std::size_t j = 0; j < m; ++j) {
            const double point[2] = {in[j], in[m + j]};
            map.eval(point, single.data());
            for (std::size_t o = 0; o < 4; ++o) {
                CAPTURE(j);
                CAPTURE(o);
                CHECK(bits(out[o * m + j]) == bits(single[o]));
            }
            finite_from_masking += std::abs(in[j]) > 1e80 && in[m + j] == 0 && std::isfinite(single[0]);
        }
        CHECK(finite_from_masking > 0);
    }
    SUBCASE("a row whose coefficient vanishes at the parameters masks its overflowing monomial, as written in") {
        // p x^4 + 3 x + 1/2 alone (a row, no group): at p = 0 it is 3 x + 1/2 even where x^4 overflows, in eval and
        // in every lane of eval_batch; at p != 0 it is infinite there
        const auto s = make_ring({"x", "p"});
        const Poly x = Poly::gen(s, 0), p = Poly::gen(s, 1);
        const Poly f = p * pow(x, 4) + Poly::constant(s, Rational(3)) * x + Poly::constant(s, Rational(1, 2));
        const CompiledMap map = CompiledMap::build({f, p * pow(x, 5)}, {0, 1}, 1);
        REQUIRE(map.tape().groups == 0);
        constexpr std::size_t m = 9;
        std::vector<double> in(2 * m), out(2 * m), single(2), scratch;
        for (std::size_t j = 0; j < m; ++j)
            in[j] = j % 3 == 0 ? 1e100 : j % 3 == 1 ? -1e90 : 0.25, in[m + j] = j % 2 ? 0.0 : 1.5;
        map.eval_batch(in.data(), out.data(), m, scratch);
        for (std::size_t j = 0; j < m; ++j) {
            CAPTURE(j);
            const double point[2] = {in[j], in[m + j]};
            map.eval(point, single.data());
            for (std::size_t o = 0; o < 2; ++o) CHECK(bits(out[o * m + j]) == bits(single[o]));
            if (in[m + j] == 0) {
                CHECK(single[0] == 3 * in[j] + 0.5);
                CHECK(bits(single[1]) == bits(0.0));
            } else if (std::abs(in[j]) > 1e80) {
                CHECK_FALSE(std::isfinite(single[0]));
            }
        }
    }
    SUBCASE("points in lanes, each with its own parameters: each lane gives eval's bits") {
        LaneCoefficients kept;
        std::vector<double> scratch;
        for (std::size_t m : {1, 3, 8, 19}) {
            std::vector<double> in(5 * m), out(O * m), point(5);
            for (std::size_t j = 0; j < m; ++j)
                for (std::size_t v = 0; v < 5; ++v) in[v * m + j] = v < 3 ? coordinate(gen) : parameter(gen);
            for (int call = 0; call < 3; ++call) {
                if (call == 2) in[3 * m + m - 1] += 0.25;  // one lane's parameter changes: its block evaluated anew
                LaneCoefficients* cache = call == 0 ? nullptr : &kept;
                two.eval_batch(in.data(), out.data(), m, scratch, cache);
                for (std::size_t j = 0; j < m; ++j) {
                    for (std::size_t v = 0; v < 5; ++v) point[v] = in[v * m + j];
                    at(point);
                    check_close(got, want, size);
                    for (std::size_t o = 0; o < O; ++o) {
                        CAPTURE(m);
                        CAPTURE(j);
                        CAPTURE(call);
                        CHECK(bits(out[o * m + j]) == bits(got[o]));
                    }
                }
            }
        }
    }
}
