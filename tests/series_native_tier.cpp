// Native code by default (NativePolicy::automatic, series/native_tier.hpp): a kept library is attached at the
// build without a compiler; a step that has run long enough builds its native code in the background and switches to it
// without changing a bit of the trajectory; no compiler means an interpreted run and a failure that names it.
#include "poisson/integrate.hpp"
#include "series/native_tier.hpp"
#include "series/machine_code.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;

namespace {

std::uint64_t bits(double v) {
    return std::bit_cast<std::uint64_t>(v);
}

// A fresh cache directory named by PGI_JIT_CACHE while it lives (the steps' NativeOptions are the defaults).
struct TestCache {
    explicit TestCache(const std::string& name)
        : dir(fs::temp_directory_path() / ("pgi-tier-test-" + std::to_string(::getpid()) + "-" + name)) {
        fs::remove_all(dir);
        ::setenv("PGI_JIT_CACHE", dir.c_str(), 1);
    }
    ~TestCache() {
        ::unsetenv("PGI_JIT_CACHE");
        fs::remove_all(dir);
    }
    std::size_t files() const {
        std::size_t n = 0;
        std::error_code ec;
        for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); ++it) ++n;
        return n;
    }
    fs::path dir;
};

// A bundled scene's stepper (the rigid body's by default) at its k and dt under policy.
NewtonStepper rigid_body_stepper(NativePolicy policy, const std::string& scene = "rigid_body") {
    const Scene s = test::bundled(scene);
    StepOptions opt;
    opt.k = s.scheme->order();
    opt.dt = s.dt;
    opt.realisation = s.scheme->realisation_choice();
    opt.native = policy;
    return s.scheme->stepper(opt, Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size())));
}

Eigen::VectorXd rigid_body_x0(const std::string& scene = "rigid_body") {
    const Scene s = test::bundled(scene);
    return Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
}

// PATH without a compiler while it lives: the key of a kept library (the command "c++ ...") is unchanged, but no
// compiler can be run.
struct NoCompilerOnPath {
    NoCompilerOnPath() : path(std::getenv("PATH") ? std::getenv("PATH") : "") { ::setenv("PATH", "/nonexistent", 1); }
    ~NoCompilerOnPath() { ::setenv("PATH", path.c_str(), 1); }
    std::string path;
};

// A map with rows of every length the interpreter has, over x, y.
CompiledMap some_map() {
    const auto r = make_ring({"x", "y"});
    const Poly x = Poly::gen(r, 0), y = Poly::gen(r, 1);
    return CompiledMap::build({pow(x, 3) - Poly::constant(r, Rational(1, 3)) * y, x * y + pow(y, 5), Poly(r)}, {0, 1});
}

// Steps a and b together from x0, n steps, requiring the same status and bits at every step.
void require_same_steps(NewtonStepper& a, NewtonStepper& b, const Eigen::VectorXd& x0, int n) {
    Eigen::VectorXd x = x0, y = x0, dx(x0.size()), dy(x0.size());
    for (int i = 0; i < n; ++i) {
        REQUIRE(a.step(x, dx) == b.step(y, dy));
        x += dx, y += dy;
        for (Eigen::Index c = 0; c < x.size(); ++c) REQUIRE(bits(x[c]) == bits(y[c]));
    }
}

}  // namespace

TEST_CASE("native tier: a kept library is attached at the build without running a compiler") {
    const TestCache cache("kept");
    NewtonStepper built = rigid_body_stepper(NativePolicy::always);
    REQUIRE(built.native_maps() > 0);
    const std::size_t files = cache.files();
    std::optional<NewtonStepper> kept;
    {
        const NoCompilerOnPath no_compiler;
        kept.emplace(rigid_body_stepper(NativePolicy::automatic));
    }
    CHECK(kept->native_maps() == built.native_maps());
    CHECK(kept->native_tier() == nullptr);
    CHECK(cache.files() == files);
    NewtonStepper never = rigid_body_stepper(NativePolicy::never);
    CHECK(never.native_maps() == 0);
    require_same_steps(*kept, never, rigid_body_x0(), 100);
}

TEST_CASE("native tier: without a kept library a step starts interpreted, with one tier for it and its copies") {
    const TestCache cache("cold");
    NewtonStepper s = rigid_body_stepper(NativePolicy::automatic);
    CHECK(s.native_maps() == 0);
    CHECK((s.info().machine_code_maps > 0) == machine_code_supported());  // (the interpreter's bits, checked below)
    REQUIRE(s.native_tier() != nullptr);
    NewtonStepper copy = s;
    CHECK(copy.native_tier() == s.native_tier());
    // a short run stays below the tier's share of the build's estimate: time counted, no build, nothing written
    NewtonStepper never = rigid_body_stepper(NativePolicy::never);
    require_same_steps(copy, never, rigid_body_x0(), 2 * int(NewtonStepper::native_sample_period));
    CHECK(s.native_tier()->spent().count() > 0);
    CHECK_FALSE(s.native_tier()->started());
    CHECK(cache.files() == 0);
}

TEST_CASE("native tier: past its share of the estimate it builds once, in the background, for every copy of the maps") {
    const TestCache cache("tier");
    CompiledMap map = some_map(), copy = map;
    NativeTier tier({&map});
    CHECK(NativeTier::estimated_build_seconds({&map}) > NativeTier::estimated_build_seconds({}));
    CHECK_FALSE(tier.spend(std::chrono::nanoseconds(1)));
    REQUIRE(tier.spend(std::chrono::seconds(100)));
    CHECK(tier.attach({&copy}) == 0);  // nothing started yet
    tier.start({&map});
    tier.start({&map});  // once
    CHECK(tier.started());
    tier.wait();
    CHECK(tier.settled());
    CHECK(tier.failure().empty());
    CHECK(tier.attach({&copy}) == 1);
    CHECK(copy.native());
    CHECK_FALSE(map.native());  // the maps the build was started from are not touched
    const double in[2] = {0.3, -1.7};
    double a[3], b[3];
    map.eval(in, a);
    copy.eval(in, b);
    for (int i = 0; i < 3; ++i) CHECK(bits(a[i]) == bits(b[i]));
}

TEST_CASE(
    "native tier: a run's expected length starts the build when the steps left repay it, and only then; machine "
    "code saves more of them") {
    CompiledMap map = some_map();
    const double build_ns = NativeTier::estimated_build_seconds({&map}) * 1e9;
    REQUIRE(build_ns > 0);
    const auto check_repaid = [&](const NativeTier& tier, double share) {
        CHECK(tier.native_share() == share);
        // repaid once (R - B)(1 - native_share) >= B: R >= B (1 + 1 / (1 - native_share))
        const double enough_ns = build_ns * (1 + 1 / (1 - share));
        const std::chrono::nanoseconds per_step(1000);
        CHECK(tier.repays(per_step, std::uint64_t(1.01 * enough_ns / 1000)));
        CHECK_FALSE(tier.repays(per_step, std::uint64_t(0.99 * enough_ns / 1000)));
    };
    check_repaid(NativeTier({&map}), NativeTier::interpreter_share);
    if (!attach_machine_code(map)) return;
    // the same maps running machine code: a build repays later, and starts after more sampled time
    NativeTier tier({&map});
    check_repaid(tier, NativeTier::machine_code_share);
    const auto threshold = [&](double share) { return NativeTier::start_share * build_ns / (1 - share); };
    const auto ns = [](double t) { return std::chrono::nanoseconds(std::int64_t(t)); };
    const double interpreted = threshold(NativeTier::interpreter_share),
                 machine = threshold(NativeTier::machine_code_share);
    CHECK_FALSE(tier.spend(ns(interpreted)));  // (where the interpreter's tier would start)
    CHECK_FALSE(tier.spend(ns(0.98 * machine - interpreted)));
    CHECK(tier.spend(ns(0.03 * machine)));
}

TEST_CASE("native tier: a long run integrate_steps drives starts the build at its first timed step; a short one not") {
    const TestCache cache("expected");
    const Eigen::VectorXd x0 = rigid_body_x0();
    const auto timed_steps = [&x0](NewtonStepper& s) {
        Eigen::VectorXd x = x0, dx(x0.size());
        for (std::uint32_t i = 0; i < NewtonStepper::native_sample_period; ++i) {
            REQUIRE(s.step(x, dx) == StepStatus::ok);
            x += dx;
        }
    };
    NewtonStepper told = rigid_body_stepper(NativePolicy::automatic);
    REQUIRE(told.native_tier() != nullptr);
    told.expect_steps(std::uint64_t(1) << 40);  // years of steps
    timed_steps(told);
    CHECK(told.native_tier()->started());
    // integrate_steps says how long its run is: its first timed step (the 256th) starts the build
    NewtonStepper driven = rigid_body_stepper(NativePolicy::automatic);
    Eigen::VectorXd y = x0;
    integrate_steps(driven, y, std::size_t(1) << 40, [](std::size_t n, double, const Eigen::VectorXd&) {
        return n == NewtonStepper::native_sample_period;
    });
    CHECK(driven.native_tier()->started());
    // and takes it back when the run ends (here at its first step)
    NewtonStepper stopped = rigid_body_stepper(NativePolicy::automatic);
    Eigen::VectorXd x = x0;
    integrate_steps(stopped, x, std::size_t(1) << 40,
                    [](std::size_t n, double, const Eigen::VectorXd&) { return n == 1; });
    timed_steps(stopped);
    CHECK_FALSE(stopped.native_tier()->started());
    stopped.expect_steps(1000);  // a thousand steps repay no compiler
    timed_steps(stopped);
    CHECK_FALSE(stopped.native_tier()->started());
}

TEST_CASE("native tier: a compiler that cannot be run leaves the maps interpreted, and the failure says why") {
    const TestCache cache("none");
    CompiledMap map = some_map();
    NativeTier tier({&map});
    {
        const NoCompilerOnPath no_compiler;
        REQUIRE(tier.spend(std::chrono::seconds(100)));
        tier.start({&map});
        tier.wait();
    }
    CHECK(tier.settled());
    CHECK(tier.failure().find("c++") != std::string::npos);
    CHECK(tier.failure().find("cannot be run") != std::string::npos);
    CHECK(tier.attach({&map}) == 0);
    CHECK_FALSE(map.native());
    CHECK(cache.files() == 0);  // no temporary left behind
}

TEST_CASE(
    "native tier: maps kept native count against the size budget, and stay counted after a failed build of the "
    "rest") {
    const TestCache cache("partial");
    const auto r = make_ring({"x", "y"});
    const Poly x = Poly::gen(r, 0), y = Poly::gen(r, 1);
    CompiledMap kept = some_map(), other = CompiledMap::build({pow(x, 4) + y, x * pow(y, 2)}, {0, 1});
    REQUIRE(attach_native_code({&kept}) == 1);  // kept from now on
    NativeOptions small;
    small.max_size = kept.num_terms() + kept.num_monomials() + other.num_terms() + other.num_monomials() - 1;
    // the budget holds the kept map and not both: nothing more to compile, and no time to spend on it
    CHECK(native_candidates({&kept, &other}, small).empty());
    CHECK(NativeTier::estimated_build_seconds({&kept, &other}, small) == 0);
    CHECK(native_candidates({&kept, &other}) == std::vector<std::size_t>{1});
    CHECK(NativeTier::estimated_build_seconds({&kept, &other}) > 0);
    // a build of the rest that fails leaves the kept map native, and says so
    NativeTier tier({&kept, &other});
    {
        const NoCompilerOnPath no_compiler;
        REQUIRE(tier.spend(std::chrono::seconds(100)));
        tier.start({&kept, &other});
        tier.wait();
    }
    CHECK_FALSE(tier.failure().empty());
    CHECK(tier.attach({&kept, &other}) == 1);
    CHECK(kept.native());
    CHECK_FALSE(other.native());
}

namespace {

// One scene's long run under automatic against the interpreter, until the tier's native code is attached.
void check_switch(const std::string& scene) {
    CAPTURE(scene);
    const TestCache cache("switch");
    NewtonStepper tiered = rigid_body_stepper(NativePolicy::automatic, scene),
                  never = rigid_body_stepper(NativePolicy::never, scene);
    REQUIRE(tiered.native_tier() != nullptr);
    const Eigen::VectorXd x0 = rigid_body_x0(scene);
    Eigen::VectorXd x = x0, y = x0, dx(x0.size()), dy(x0.size());
    // the tier starts the build after about start_share of its estimate (a second or so) and the compiler takes about
    // the estimate: a minute is far beyond both, even on a loaded machine
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(1);
    std::size_t steps = 0;
    while (tiered.native_maps() == 0 && tiered.native_failure().empty() && std::chrono::steady_clock::now() < give_up) {
        REQUIRE(tiered.step(x, dx) == never.step(y, dy));
        x += dx, y += dy, ++steps;
        for (Eigen::Index c = 0; c < x.size(); ++c) REQUIRE(bits(x[c]) == bits(y[c]));
    }
    CAPTURE(steps);
    REQUIRE(tiered.native_failure() == "");
    REQUIRE(tiered.native_maps() > 0);
    CHECK(tiered.native_tier() == nullptr);
    require_same_steps(tiered, never, x, 1000);
    CHECK(cache.files() > 0);  // kept: the next stepper of these maps attaches it at its build
    CHECK(rigid_body_stepper(NativePolicy::automatic, scene).native_maps() == tiered.native_maps());
}

}  // namespace

TEST_CASE("native tier: a long run switches to native code mid-run and keeps the interpreter's bits" *
          doctest::skip(test::sanitized)) {
    check_switch("rigid_body");
}

// Maps that read a scheme's parameters get native code built for their structure, whatever the values.
TEST_CASE("native tier: with parameters too, the switch keeps the interpreter's bits" *
          doctest::skip(test::sanitized)) {
    check_switch("rigid_body_parameters");
}
