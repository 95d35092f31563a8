// The budget of the exact phase (series/budget.hpp): terms, memory and time, checked between the
// operations and estimated before the predictable ones; refusals name the stage, the size and the budget.
#include "poisson/hamilton_jacobi.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>
#include <sys/mman.h>

#include <string>

using namespace pgi;

namespace {

std::vector<std::string> names(std::size_t n) {
    std::vector<std::string> v;
    for (std::size_t i = 1; i <= n; ++i) v.push_back("x" + std::to_string(i));
    return v;
}

// sum_{i<m} c_i x1^(i mod 50) x2^(i div 50 + shift) with coefficients of about `bits` bits: m terms, all
// distinct, the exponents far below the reader's limit of 1000. Added in pairs: each term is copied
// O(log m) times, so building it moves the resident memory little (even under AddressSanitizer, which keeps
// what is freed in quarantine).
Poly wide(const RingPtr& r, std::size_t m, std::size_t bits, std::size_t shift) {
    std::vector<Poly> terms;
    for (std::size_t i = 0; i < m; ++i) {
        std::string c = "2^" + std::to_string(bits) + " + " + std::to_string(i + shift);
        terms.push_back(
            Poly::parse(r, "(" + c + ")*x1^" + std::to_string(i % 50) + "*x2^" + std::to_string(i / 50 + shift)));
    }
    for (std::size_t width = 1; width < m; width *= 2)
        for (std::size_t i = 0; i + width < m; i += 2 * width) terms[i] += terms[i + width];
    return terms.empty() ? Poly(r) : terms.front();
}

}  // namespace

// issue 11.3
TEST_CASE("sums are bounded by the ring's term budget, not only products") {
    auto r = make_ring(names(2), 50);
    Poly sum(r);
    CHECK_THROWS_WITH_AS(
        [&] {
            for (int i = 0; i < 60; ++i) sum += pow(Poly::gen(r, 0), static_cast<unsigned long>(i));
        }(),
        doctest::Contains("a sum reached 51 terms, above the limit of 50 (raise it with --max-terms or max_terms)"),
        ResourceLimitError);
    CHECK(sum.length() <= 51);  // refused at the first result above the bound, not later
}

// issue 11.3
TEST_CASE("a product is refused before it is formed when its bytes would exceed the memory budget") {
    // 1500 x 1500 terms is below the term bound; with 40 variables and 600-bit coefficients the product
    // could take 2.25e6 * (6 exponent words + a 1200-bit coefficient) bytes, about 500 MB: far above a budget
    // of 64 MB more than the process holds now, whatever the resident memory does meanwhile (under
    // AddressSanitizer it moves by megabytes between two readings: a 20 MB product once fitted an 8 MB headroom).
    const std::size_t headroom = 64u << 20;
    auto budget =
        std::make_shared<const Budget>(BudgetLimits{.max_bytes = resident_memory() + headroom, .address_space = false});
    auto r = make_ring(names(40), budget);
    Poly a = wide(r, 1500, 600, 0), b = wide(r, 1500, 600, 7);
    const std::size_t before = resident_memory();
    try {
        (void)(a * b);
        FAIL("the product was formed");
    } catch (const BudgetExceeded& e) {
        CHECK(e.resource() == BudgetExceeded::Resource::memory);
        CHECK_MESSAGE(
            std::string(e.what()).find("a product of a 1500-term and a 1500-term polynomial could take ") == 0,
            e.what());
        CHECK_MESSAGE(
            std::string(e.what()).find("(raise it with --max-memory-mb or max_memory_mb)") != std::string::npos,
            e.what());
    }
    CHECK(resident_memory() < before + headroom);  // nothing of the size was allocated
    // with room for it, the same product is formed: the estimate is an upper bound, not a guess
    auto roomy = make_ring(names(40), std::make_shared<const Budget>(BudgetLimits{
                                          .max_bytes = resident_memory() + (512u << 20), .address_space = false}));
    const Poly c = wide(roomy, 300, 600, 0) * wide(roomy, 300, 600, 7);
    CHECK(c.length() > 300);
    CHECK(c.length() <= 90000);
}

// A limit of ulimit -v caps the address space, which runs 40-50 MB above the resident memory: a budget of resident
// memory at 3/4 of the cap let FLINT fail (exit 5) before the budget stopped the phase (exit 4).
// (Not under AddressSanitizer, whose reserves are terabytes of address space.)
TEST_CASE("a budget of the address space counts reserved memory that is not resident; one of resident memory not" *
          doctest::skip(pgi::test::sanitized)) {
    // 512 MB of address space, never accessible: none of it resident, and nothing charged to the system
    constexpr std::size_t reserve = std::size_t(512) << 20;
    void* block = ::mmap(nullptr, reserve, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    REQUIRE_MESSAGE(block != MAP_FAILED, "512 MB of address space could not be reserved (a ulimit -v below it?)");
    CHECK(memory_in_use(true) >= resident_memory() + reserve);
    CHECK(memory_in_use(false) < resident_memory() + reserve / 2);
    // the memory is polled at an account() (every 32nd) at most every 20 ms: the first poll is due at once
    const auto polled = [](bool address_space) {
        const Budget b(BudgetLimits{.max_bytes = resident_memory() + reserve / 2, .address_space = address_space});
        for (int i = 0; i < 32; ++i) b.account("a sum", 1);
    };
    CHECK_THROWS_AS(polled(true), BudgetExceeded);
    CHECK_NOTHROW(polled(false));
    ::munmap(block, reserve);
}

// issue 11.3
TEST_CASE("the estimate of a product counts the variables and the coefficient sizes") {
    const double few = bytes_per_term(2, 10, 10), many = bytes_per_term(60, 10, 10), big = bytes_per_term(2, 10, 6400);
    CHECK(few == 16);          // one exponent word (3 fields of 8 bits) and one coefficient word
    CHECK(many == 8 * 8 + 8);  // 61 fields of 8 bits: 8 words
    CHECK(big == 8 + 8 + 16 + 8 * 100);
    CHECK(bytes_per_term(2, 1000, 10) == 8 + 8);      // 16-bit fields: still one word
    CHECK(bytes_per_term(8, 1000, 10) == 3 * 8 + 8);  // 9 fields of 16 bits: 3 words
    CHECK(monomials_up_to(6, 1000) == doctest::Approx(1418299634202451.0).epsilon(1e-12));  // binomial(1006, 6)
    CHECK(monomials_up_to(3, 2) == 10);
}

// issue 11.3
TEST_CASE("the time budget stops an exact computation between operations, naming its stage") {
    auto budget = std::make_shared<const Budget>(BudgetLimits{.max_seconds = 1e-9});
    auto r = make_ring(names(2), budget);
    BudgetStage stage(*budget, "Hamilton-Jacobi term S_2", 2, 3);
    try {
        Poly f = Poly::gen(r, 0);
        for (int i = 0; i < 1000000; ++i) f += Poly::gen(r, 1);
        FAIL("no refusal");
    } catch (const BudgetExceeded& e) {
        CHECK(e.resource() == BudgetExceeded::Resource::time);
        CHECK_MESSAGE(std::string(e.what()).find("Hamilton-Jacobi term S_2 (2 of 3): the exact phase has run ") == 0,
                      e.what());
        CHECK_MESSAGE(
            std::string(e.what()).find(
                "above the time budget of 1e-09 s (raise it with --max-seconds or max_seconds)") != std::string::npos,
            e.what());
    }
}

// issue 11.3
TEST_CASE("a refusal inside the Hamilton-Jacobi terms names the term as k of K") {
    PhaseSpace M({"x1", "x2", "x3"}, 60);  // so(3), 60 terms: its realisation fits, the terms of a cubic H do not
    std::vector<std::vector<Poly>> m(3, std::vector<Poly>(3, Poly(M.ring())));
    for (auto [i, j, s] : {std::tuple{0, 1, "x3"}, {1, 2, "x1"}, {2, 0, "x2"}}) {
        m[i][j] = M.parse(s);
        m[j][i] = -m[i][j];
    }
    PoissonStructure pi(M, m);
    Realisation real = build_realisation(pi, RealisationChoice::automatic, realisation_degree_for_order(12));
    try {
        hamilton_jacobi_terms(M, real, M.parse("x1^2/2 + x2^2/3 + x3^2/7 + x1*x2*x3"), 12);
        FAIL("no refusal");
    } catch (const BudgetExceeded& e) {
        const std::string what = e.what();
        CHECK_MESSAGE(what.find("Hamilton-Jacobi term S_") == 0, what);
        CHECK_MESSAGE(what.find(" of 12): ") != std::string::npos, what);
        CHECK_MESSAGE(what.find("above the limit of 60 (raise it with --max-terms or max_terms)") != std::string::npos,
                      what);
    }
}

TEST_CASE("budget_limits: the user's three values, memory in MB of the resident set, a non-positive time refused") {
    const BudgetLimits given = budget_limits(10, 3, 2.5);
    CHECK(given.max_terms == 10);
    CHECK(given.max_bytes == std::size_t(3) << 20);
    CHECK_FALSE(given.address_space);
    CHECK(given.max_seconds == 2.5);
    const BudgetLimits defaults = budget_limits(10, 0, std::numeric_limits<double>::infinity());
    CHECK(defaults.max_bytes == default_memory_budget());
    CHECK(defaults.address_space == default_memory_budget_is_address_space());
    CHECK(budget_limits(1, SIZE_MAX, 1).max_bytes == (SIZE_MAX >> 20) << 20);  // clamped, not wrapped
    for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()})
        CHECK_THROWS_WITH_AS(budget_limits(1, 0, bad), doctest::Contains("max_seconds: must be positive"),
                             std::invalid_argument);
}
