// Machine code for compiled maps (series/machine_code.hpp): the interpreter's bits on random maps (rows, groups in
// pairs and in fours, signed zeros, overflow, NaN), with parameters at values where coefficients vanish, on a map whose
// monomials span several pages of stack, from several threads at once; a map too large stays interpreted.
#include "series/machine_code.hpp"
#include "series/poly.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <thread>

using namespace pgi;

namespace {

std::uint64_t bits(double v) {
    return std::bit_cast<std::uint64_t>(v);
}

// Compares machine's outputs with interpreted's at `points` random points of `inputs` coordinates in [-2, 2] (the
// first `fixed` of `fixed_values` instead: parameters), with signed zeros, an overflowing input and a NaN among them;
// returns how many outputs were compared.
std::size_t compare(const CompiledMap& interpreted, const CompiledMap& machine, std::mt19937& gen, int points,
                    const std::vector<double>& tail = {}) {
    std::uniform_real_distribution<double> input(-2.0, 2.0);
    const std::size_t n = machine.num_inputs() - tail.size(), O = machine.num_outputs();
    std::vector<double> x(machine.num_inputs()), a(O), b(O);
    std::size_t compared = 0;
    for (int point = 0; point < points; ++point) {
        for (std::size_t v = 0; v < n; ++v) x[v] = input(gen);
        std::copy(tail.begin(), tail.end(), x.begin() + std::ptrdiff_t(n));
        if (point == 1) x[0] = -0.0, x[1 % n] = 0.0;
        if (point == 2) x[n - 1] = 1e120;
        if (point == 3) x[0] = std::numeric_limits<double>::quiet_NaN();
        interpreted.eval(x.data(), a.data());
        machine.eval(x.data(), b.data());
        for (std::size_t o = 0; o < O; ++o) {
            CAPTURE(point);
            CAPTURE(o);
            CHECK(bits(a[o]) == bits(b[o]));
            ++compared;
        }
    }
    return compared;
}

}  // namespace

TEST_CASE(
    "machine code: every output is the interpreter's, bit for bit, on random maps with rows and groups summed in "
    "pairs or in fours") {
    if (!machine_code_supported()) {
        MESSAGE("this processor has no AVX: no machine code is written");
        return;
    }
    const auto r = make_ring({"unused", "a", "b", "c"});
    for (const GroupVectors vectors : {GroupVectors::sse2, GroupVectors::avx2}) {
        if (vectors == GroupVectors::avx2 && !processor_has_avx2()) continue;
        CAPTURE(static_cast<int>(vectors));
        std::mt19937 gen(33);
        std::size_t compared = 0;
        for (int trial = 0; trial < 4; ++trial) {
            CompiledMap map = CompiledMap::build(test::mixed_outputs(r, gen), {3, 1, 2});
            map.set_group_vectors(vectors);
            REQUIRE(map.tape().groups > 0);
            const CompiledMap interpreted = map;
            REQUIRE(attach_machine_code(map));
            CHECK(map.machine_code());
            CHECK_FALSE(map.native());
            CHECK_FALSE(interpreted.machine_code());
            const CompiledMap copy = map;  // (shares the code)
            CHECK(copy.machine_code());
            compared += compare(interpreted, copy, gen, 200);
        }
        CHECK(compared > 5000);
    }
}

TEST_CASE("machine code: a map with parameters gives the interpreter's bits at values where coefficients vanish") {
    if (!machine_code_supported()) return;
    const auto r = make_ring({"unused", "a", "b", "c", "p", "q"});
    std::mt19937 gen(9);
    const std::vector<Poly> outputs = test::outputs_with_parameters(r, gen);
    CompiledMap map = CompiledMap::build(outputs, {3, 1, 2, 4, 5}, 2);
    REQUIRE(map.tape().groups > 0);
    const CompiledMap interpreted = map;
    REQUIRE(attach_machine_code(map));
    std::size_t compared = 0;
    for (const auto& pq : {std::vector{0.5, -1.5}, {1.0, 0.25}, {4.0, 2.0}, {1.0, 1.0}})
        compared += compare(interpreted, map, gen, 100, pq);
    CHECK(compared > 3000);
}

TEST_CASE(
    "machine code: a map whose monomials fill several pages of stack, evaluated on threads at once; a map over "
    "the size limit stays interpreted") {
    if (!machine_code_supported()) return;
    const auto r = make_ring({"x", "y", "z"});
    const auto sum_of_monomials = [&](unsigned degree) {
        std::vector<Poly> outputs(4, Poly(r));
        std::mt19937 gen{degree};
        std::uniform_int_distribution<long> coeff(-50, 50);
        for (unsigned i = 0; i <= degree; ++i)
            for (unsigned j = 0; i + j <= degree; ++j)
                for (unsigned k = 0; i + j + k <= degree; ++k) {
                    const Poly m = pow(Poly::gen(r, 0), i) * pow(Poly::gen(r, 1), j) * pow(Poly::gen(r, 2), k);
                    outputs[(i + j + k) % 4] += Poly::constant(r, Rational(coeff(gen), 16)) * m;
                }
        return CompiledMap::build(outputs, {0, 1, 2});
    };
    CompiledMap map = sum_of_monomials(14);  // 680 monomials: 5.4 KB of stack
    REQUIRE(map.num_monomials() > 4096 / 8);
    REQUIRE(map.num_terms() + map.num_monomials() <= machine_code_max_size);
    const CompiledMap interpreted = map;
    REQUIRE(attach_machine_code(map));
    std::vector<std::size_t> counts(2);
    std::vector<std::thread> threads;
    for (std::size_t t = 0; t < counts.size(); ++t)
        threads.emplace_back(
            [&, t, own = interpreted] {  // (the interpreter's scratch is its own; map's code is shared)
                std::mt19937 gen{unsigned(t)};
                std::uniform_real_distribution<double> input(-1.1, 1.1);
                std::vector<double> x(3), a(4), b(4);
                for (int point = 0; point < 2000; ++point) {
                    for (double& v : x) v = input(gen);
                    own.eval(x.data(), a.data());
                    map.eval(x.data(), b.data());
                    for (std::size_t o = 0; o < 4; ++o) counts[t] += bits(a[o]) == bits(b[o]);
                }
            });
    for (auto& th : threads) th.join();
    CHECK(counts[0] == 8000);
    CHECK(counts[1] == 8000);

    CompiledMap large = sum_of_monomials(24);  // 2925 monomials and as many terms
    REQUIRE(large.num_terms() + large.num_monomials() > machine_code_max_size);
    CHECK_FALSE(attach_machine_code(large));
    CHECK_FALSE(large.machine_code());
}

TEST_CASE("machine code: outputs written over the inputs are the interpreter's; a moved-from map has no code") {
    if (!machine_code_supported()) return;
    const auto r = make_ring({"x", "y"});
    const Poly x = Poly::gen(r, 0), y = Poly::gen(r, 1);
    CompiledMap map = CompiledMap::build({y, x, x * y}, {0, 1});  // (y, x, x y): each output reads the other input
    const CompiledMap interpreted = map;
    REQUIRE(attach_machine_code(map));
    double a[3] = {1, 2, 0}, b[3] = {1, 2, 0};
    interpreted.eval(a, a);
    map.eval(b, b);
    CHECK(a[0] == 2);
    CHECK(a[1] == 1);
    CHECK(a[2] == 2);
    for (int i = 0; i < 3; ++i) CHECK(bits(a[i]) == bits(b[i]));
    CompiledMap moved = std::move(map);
    CHECK(moved.machine_code());
    CHECK_FALSE(map.machine_code());  // NOLINT(bugprone-use-after-move): what a moved-from map says of itself
}
