// CompiledMap::eval_batch: m points at once in structure-of-arrays layout, each lane bit for bit eval()'s.
#include "series/compile.hpp"
#include "series/poly.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cstdlib>
#include <cstdint>
#include <random>

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
            Poly m = Poly::constant(r, Rational(coeff(gen), static_cast<unsigned long>(1 + std::abs(coeff(gen)))));  // not dyadic: rounded coefficients
            for (std::size_t v = 0; v < k; ++v) m = m * pow(Poly::gen(r, v + 1), ex(gen));
            f += m;
        }
        outputs.push_back(f);
    }
    return outputs;
}

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

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
