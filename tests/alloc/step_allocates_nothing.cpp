// A separate test program (it replaces malloc to count calls): the compiled step allocates nothing.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include "poisson/integrate.hpp"
#include "scheme/scene.hpp"

#include <doctest/doctest.h>

#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <unistd.h>

#include "tests/alloc/count_malloc.hpp"

TEST_CASE("newton_step: no allocation in the hot loop, for every realisation form, interpreted and native") {
    // native code's libraries go to a directory of this run's, removed at the end (not the user's cache)
    const std::filesystem::path cache =
        std::filesystem::temp_directory_path() / ("pgi-alloc-test-" + std::to_string(::getpid()));
    ::setenv("PGI_JIT_CACHE", cache.c_str(), 1);
    for (const std::string name : {"rigid_body", "lotka_volterra", "nambu", "henon_heiles", "volterra_chain"})
        for (const bool jit : {false, true}) {
            pgi::Scene s = pgi::load_scene(std::string(PGI_SCENES_DIR) + "/" + name + ".toml");
            Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
            for (std::size_t k : {1, 4}) {
                pgi::StepOptions opt;
                opt.k = k;
                opt.dt = s.dt;
                opt.native = jit ? pgi::NativePolicy::always : pgi::NativePolicy::never;
                auto st = pgi::NewtonStepper::build(s.pi, s.H, opt, x);
                CHECK((st.info().native_maps > 0) == jit);
                Eigen::VectorXd inc(x.size());
                allocations = 0;
                counting = true;
                for (int n = 0; n < 200; ++n) {
                    // dt is a run-time argument: a smaller one alternates with the built one
                    if (st.step(x, n % 2 ? s.dt : s.dt / 3, inc) != pgi::StepStatus::ok) break;
                    x += inc;
                }
                counting = false;
                CAPTURE(name);
                CAPTURE(k);
                CAPTURE(jit);
                CHECK(allocations == 0);
                // the counter does count: a heap vector is one allocation
                counting = true;
                Eigen::VectorXd probe(64);
                counting = false;
                CHECK(allocations == 1);
            }
        }
    ::unsetenv("PGI_JIT_CACHE");
    std::filesystem::remove_all(cache);
}

// issue 16.1
TEST_CASE("no allocation in the Lie-Poisson step past its series' radius (scaling and squaring)") {
    // sl(2)* at dt = 1/4 from (0.5, 1, -2): |L(p)| ~ 6, beyond the radius of every series degree
    pgi::PhaseSpace M({"h", "e", "f"});
    std::vector<std::vector<pgi::Poly>> pi(3, std::vector<pgi::Poly>(3, pgi::Poly(M.ring())));
    const auto set = [&](int i, int j, const char* s) { pi[i][j] = M.parse(s), pi[j][i] = -pi[i][j]; };
    set(0, 1, "2*e");
    set(0, 2, "-2*f");
    set(1, 2, "h");
    const pgi::PoissonStructure structure(M, pi);
    Eigen::VectorXd x(3);
    x << 0.5, 1, -2;
    pgi::StepOptions opt;
    opt.k = 1;
    opt.dt = 0.25;
    auto st = pgi::NewtonStepper::build(structure, M.parse("h^2 + 2*e^2 + 2*f^2"), opt, x);
    Eigen::VectorXd inc(3);
    allocations = 0;
    counting = true;
    int ok = 0;
    for (int n = 0; n < 20; ++n) {
        if (st.step(x, inc) != pgi::StepStatus::ok) break;
        x += inc;
        ++ok;
    }
    counting = false;
    CHECK(ok == 20);
    CHECK(allocations == 0);
}
