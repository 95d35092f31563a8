// Local storage (series/poly, docs/math.md 5): a ring whose polynomials keep their terms over the variables they
// hold computes exactly what dense storage computes, keeps that invariant after every operation, and keeps a
// polynomial of a few variables as small in a ring of thousands of variables as in a ring of its own.
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/newton_step.hpp"
#include "poisson/realisation.hpp"
#include "series/compile.hpp"
#include "series/poly.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <random>

using namespace pgi;

namespace {

std::vector<std::string> numbered(const char* stem, std::size_t n) {
    std::vector<std::string> v;
    for (std::size_t i = 1; i <= n; ++i) v.push_back(stem + std::to_string(i));
    return v;
}

// The variables f's terms hold, read from its terms one by one (not from its storage).
std::vector<std::size_t> held(const Poly& f) {
    std::vector<bool> any(f.ring()->size(), false);
    for (std::size_t t = 0; t < f.length(); ++t) {
        const auto e = f.term_exponents(t);
        for (std::size_t v = 0; v < e.size(); ++v) any[v] = any[v] || e[v] != 0;
    }
    std::vector<std::size_t> vars;
    for (std::size_t v = 0; v < any.size(); ++v)
        if (any[v]) vars.push_back(v);
    return vars;
}

// The same polynomial in two rings of the same names, one dense and one local: the same terms in the same order
// (the printed form lists them in the ring's order), and the local one stored over exactly what it holds.
void same(const Poly& dense, const Poly& local) {
    REQUIRE(!dense.ring()->local_storage());
    REQUIRE(local.ring()->local_storage());
    CHECK(dense.to_string() == local.to_string());
    CHECK(dense.length() == local.length());
    const auto vars = local.variables();
    CHECK(std::vector<std::size_t>(vars.begin(), vars.end()) == held(local));
    CHECK(used_variables(local) == held(local));
    CHECK(used_variables(dense) == held(dense));
}

// A random polynomial whose terms hold one to three of the ring's variables (sparse, like a lattice's), drawn
// from a seed: the same draw in any ring of as many variables.
Poly random_sparse(const RingPtr& r, unsigned seed, int terms) {
    std::mt19937 gen(seed);
    std::uniform_int_distribution<long> coeff(-9, 9);
    std::uniform_int_distribution<unsigned long> den(1, 4), ex(1, 3), count(0, 3);
    std::uniform_int_distribution<std::size_t> var(0, r->size() - 1);
    std::vector<Poly> pieces;
    for (int t = 0; t < terms; ++t) {
        Poly m = Poly::constant(r, Rational(coeff(gen), den(gen)));
        for (unsigned long c = count(gen); c > 0; --c) m = m * pow(Poly::gen(r, var(gen)), ex(gen));
        pieces.push_back(std::move(m));
    }
    return sum(std::move(pieces), r);
}

struct Twins {
    RingPtr dense, local;
    explicit Twins(std::size_t n)
        : dense(std::make_shared<const Ring>(numbered("x", n), Ring::default_max_terms, PolyStorage::dense)),
          local(std::make_shared<const Ring>(numbered("x", n), Ring::default_max_terms, PolyStorage::local)) {}
};

}  // namespace

TEST_CASE("local storage: every operation gives dense storage's polynomial, stored over exactly what it holds") {
    const Twins R(9);
    const VarMask mask{true, false, true, false, false, true, false, false, true};
    for (unsigned seed = 1; seed <= 30; ++seed) {
        CAPTURE(seed);
        const Poly fd = random_sparse(R.dense, seed, 6), fl = random_sparse(R.local, seed, 6);
        const Poly gd = random_sparse(R.dense, 100 + seed, 4), gl = random_sparse(R.local, 100 + seed, 4);
        same(fd, fl);
        same(fd + gd, fl + gl);
        same(fd - gd, fl - gl);
        same(fd - fd, fl - fl);  // everything cancels: no variables left
        same(fd * gd, fl * gl);
        same(pow(fd, 2), pow(fl, 2));
        same(pow(fd, 0), pow(fl, 0));
        same(-fd, -fl);
        same(Rational(0) * fd, Rational(0) * fl);
        same(sum({fd, gd, -fd, fd * gd}, R.dense), sum({fl, gl, -fl, fl * gl}, R.local));
        for (std::size_t v = 0; v < 9; ++v) same(derivative(fd, v), derivative(fl, v));
        for (unsigned long m = 0; m <= 3; ++m) same(homogeneous_part(fd, mask, m), homogeneous_part(fl, mask, m));
        same(truncate(fd, mask, 2), truncate(fl, mask, 2));
        CHECK(masked_degree(fd, mask) == masked_degree(fl, mask));
        std::vector<Poly> images_d, images_l;  // x_v -> a small random polynomial, or x_v itself
        for (std::size_t v = 0; v < 9; ++v) {
            images_d.push_back(v % 3 == 0 ? random_sparse(R.dense, 200 + seed + unsigned(v), 2)
                                          : Poly::gen(R.dense, v));
            images_l.push_back(v % 3 == 0 ? random_sparse(R.local, 200 + seed + unsigned(v), 2)
                                          : Poly::gen(R.local, v));
        }
        same(substitute(fd, images_d), substitute(fl, images_l));
        CHECK((fd + gd == gd + fd));
        CHECK((fl + gl == gl + fl));
        CHECK(((fl - gl) == fl) == gl.is_zero());
        const std::vector<double> point{0.5, -1.25, 2, 0.75, -0.5, 1.5, 3, -2, 0.25};
        CHECK(evaluate(fd, point) == evaluate(fl, point));  // the same terms in the same order: the same bits
    }
}

TEST_CASE("local storage: high degrees keep FLINT's room for overflow when moved between contexts") {
    // a term of degree 128..255 fills 8 bits: moved into a larger context it needs 9 (FLINT keeps each field's top
    // bit zero and reads a set one as an overflow), and products and sums of such terms must still be dense storage's
    const Twins R(70);
    const auto both = [&](const std::string& text) {
        return std::pair{Poly::parse(R.dense, text), Poly::parse(R.local, text)};
    };
    for (const char* a : {"x1^130*x2^70 + x3", "x5^127 + x6^128", "x1^255 - 3*x70^200*x2"}) {
        CAPTURE(a);
        const auto [fd, fl] = both(a);
        const auto [gd, gl] = both("x2^100*x69 + 2*x40^60 - x1^130*x2^70");
        same(fd, fl);
        same(fd + gd, fl + gl);
        same(fd * gd, fl * gl);
        same(fd * fd - gd, fl * fl - gl);
        same(sum({fd, gd, fd * gd}, R.dense), sum({fl, gl, fl * gl}, R.local));
        same(derivative(fd * gd, 1), derivative(fl * gl, 1));
        // moved to all 70 variables, where 8 bits a field (eight fields a word) is what FLINT's rounding leaves
        std::vector<Poly> gens_d, gens_l;
        for (std::size_t v = 0; v < 70; ++v)
            gens_d.push_back(Poly::gen(R.dense, v)), gens_l.push_back(Poly::gen(R.local, v));
        const Poly all_d = sum(gens_d, R.dense), all_l = sum(gens_l, R.local);
        for (const Poly* p : {&fl, &gl}) {
            const Poly q = *p + all_l;
            REQUIRE(q.variables().size() == 70);
            CHECK(FLINT_BIT_COUNT(static_cast<ulong>(q.total_degree())) <
                  q.get()->zpoly->bits);  // the top bit stays free
        }
        same(fd + all_d, fl + all_l);
        same((fd + all_d) * (gd - all_d), (fl + all_l) * (gl - all_l));
    }
}

TEST_CASE("local storage: whatever cancels gives its variables back") {
    const Twins R(4);
    const auto x = [&](std::size_t v) { return Poly::gen(R.local, v); };
    const auto over = [](const Poly& f) {
        return std::vector<std::uint32_t>(f.variables().begin(), f.variables().end());
    };
    using V = std::vector<std::uint32_t>;
    Poly f = x(0) + x(1);
    CHECK(over(f) == V{0, 1});
    f += -x(1);
    CHECK(over(f) == V{0});
    f -= x(0);
    CHECK(over(f) == V{});
    CHECK(f.is_zero());
    CHECK(over(sum({x(2) * x(3), x(0), -(x(2) * x(3))}, R.local)) == V{0});
    CHECK(over(derivative(x(1) * x(2) + x(3), 1)) == V{2});
    CHECK(over(derivative(x(1), 2)) == V{});
    Poly g = x(1) * x(3);
    g *= Rational(0);
    CHECK(over(g) == V{});
    CHECK(over(x(1) * Poly(R.local)) == V{});
    CHECK(over(truncate(x(0) * x(1) + x(2), VarMask{true, false, false, false}, 0)) == V{2});
    const std::vector<Poly> images{x(0), Poly::constant(R.local, 2), x(2), x(3)};
    CHECK(over(substitute(x(0) * x(1) - 2 * x(0) + x(3), images)) == V{3});
    CHECK(((x(0) + x(1)) - x(1) == x(0)));
}

TEST_CASE("local storage: a change of ring, in order or not, one to one or merging variables") {
    const Twins from(6), to(8);
    const std::vector<long> in_order{0, 1, 3, 4, 6, 7}, permuted{7, 2, 5, 0, 1, 3}, merging{0, 0, 1, 1, 2, 2};
    for (unsigned seed = 1; seed <= 20; ++seed) {
        CAPTURE(seed);
        const Poly fd = random_sparse(from.dense, seed, 6), fl = random_sparse(from.local, seed, 6);
        for (const auto* map : {&in_order, &permuted, &merging}) {
            same(rename_variables(fd, to.dense, *map), rename_variables(fl, to.local, *map));
            // and between the two kinds of storage
            same(rename_variables(fl, to.dense, *map), rename_variables(fd, to.local, *map));
        }
    }
}

TEST_CASE("local storage: compiled maps of the same polynomials give the same bits") {
    const Twins R(7);
    std::vector<Poly> outs_d, outs_l;
    for (unsigned seed = 1; seed <= 5; ++seed) {
        outs_d.push_back(random_sparse(R.dense, seed, 8));
        outs_l.push_back(random_sparse(R.local, seed, 8));
    }
    const std::vector<std::size_t> inputs{0, 1, 2, 3, 4, 5, 6};
    const CompiledMap cd = CompiledMap::build(outs_d, inputs), cl = CompiledMap::build(outs_l, inputs);
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> u(-2, 2);
    std::vector<double> x(7), yd(outs_d.size()), yl(outs_l.size());
    for (int trial = 0; trial < 50; ++trial) {
        for (double& xi : x) xi = u(gen);
        cd.eval(x.data(), yd.data());
        cl.eval(x.data(), yl.data());
        CHECK(yd == yl);
    }
}

TEST_CASE("local storage: a polynomial of few variables stays small in a ring of thousands") {
    const std::size_t n = 4000;
    const auto r = make_ring(numbered("x", n));  // automatic: local from Ring::local_storage_from on
    REQUIRE(r->local_storage());
    const Poly f = Poly::gen(r, 0) * Poly::gen(r, n - 1) + Poly::constant(r, 3);
    CHECK(f.variables().size() == 2);
    CHECK(f.ctx()->zctx->minfo->nvars == 2);
    CHECK(mpoly_words_per_exp(f.get()->zpoly->bits, f.ctx()->zctx->minfo) == 1);
    // A sum over every variable is stored over all of them, in as few bits as its degree needs: its pieces were
    // formed in small contexts, whose fields FLINT widens to fill a word (32 bits for two variables), which a
    // sum over 4000 variables must not inherit (4x the bytes of every term).
    std::vector<Poly> pieces;
    for (std::size_t i = 0; i < n; ++i) pieces.push_back(Poly::gen(r, i) * Poly::gen(r, (i + 1) % n));
    const Poly g = sum(std::move(pieces), r);
    CHECK(g.length() == n);
    CHECK(g.variables().size() == n);
    CHECK(g.get()->zpoly->bits == MPOLY_MIN_BITS);
    // and its derivative is back to the three variables it holds
    const Poly d = derivative(g, 7);
    CHECK(d.to_string() == "x7 + x9");
    CHECK(d.ctx()->zctx->minfo->nvars == 2);
}

TEST_CASE("local storage: a lattice's Hamilton-Jacobi terms and steps are dense storage's, bit for bit") {
    const std::size_t n = 12;
    const auto names = numbered("x", n);
    std::vector<std::tuple<int, int, std::string>> brackets;
    for (std::size_t i = 0; i < n; ++i)
        brackets.emplace_back(int(i), int((i + 1) % n), names[i] + "*" + names[(i + 1) % n]);
    const PoissonStructure pd = test::structure(names, brackets, PolyStorage::dense);
    const PoissonStructure pl = test::structure(names, brackets, PolyStorage::local);
    const Poly Hd = pd.phase_space().parse("x1 + x2 + x3 + x4 + x5 + x6 + x7 + x8 + x9 + x10 + x11 + x12 + x3*x7");
    const Poly Hl = pl.phase_space().parse("x1 + x2 + x3 + x4 + x5 + x6 + x7 + x8 + x9 + x10 + x11 + x12 + x3*x7");
    same(Hd, Hl);
    const Realisation rd = build_realisation(pd, RealisationChoice::automatic, 3),
                      rl = build_realisation(pl, RealisationChoice::automatic, 3);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t m = 0; m < rd.alpha[i].order(); ++m) same(rd.alpha[i][m], rl.alpha[i][m]);
    const auto Sd = hamilton_jacobi_terms(pd.phase_space(), rd, Hd, 4),
               Sl = hamilton_jacobi_terms(pl.phase_space(), rl, Hl, 4);
    for (std::size_t j = 0; j < Sd.size(); ++j) same(Sd[j], Sl[j]);
    StepOptions opt;
    opt.k = 4;
    opt.dt = 0.05;
    Eigen::VectorXd x(static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i) x[Eigen::Index(i)] = 1.0 + 0.3 * std::sin(double(i));
    NewtonStepper sd = NewtonStepper::build(pd, Hd, opt, x), sl = NewtonStepper::build(pl, Hl, opt, x);
    Eigen::VectorXd a(x.size()), b(x.size());
    for (int m = 0; m < 20; ++m) {
        REQUIRE(sd.step(x, a) == StepStatus::ok);
        REQUIRE(sl.step(x, b) == StepStatus::ok);
        CHECK(a == b);
        x += a;
    }
}
