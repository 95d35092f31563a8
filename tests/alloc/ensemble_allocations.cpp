// A separate test program (it replaces malloc to count calls): an ensemble allocates per trajectory and per
// task, never per step, so the count does not grow with the number of steps.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include "scheme/ensemble.hpp"
#include "scheme/scene.hpp"

#include <doctest/doctest.h>

#include <cstddef>

#include "tests/alloc/count_malloc.hpp"

namespace {
long allocations_of(const pgi::Scheme& scheme, const pgi::RowMatrix& X0, double t_end, std::size_t threads) {
    pgi::EnsembleOptions o;
    o.threads = threads;
    o.chunk = 2;
    allocations = 0;
    counting = true;
    const auto r = pgi::integrate_ensemble(scheme, X0, 0.1, t_end, o);
    counting = false;
    CHECK(r.members.back().steps == std::size_t(t_end / 0.1 + 0.5));
    return allocations;
}
}  // namespace

TEST_CASE("ensemble: no allocation per step") {
    for (const std::string name : {"rigid_body", "volterra_chain"}) {
        CAPTURE(name);
        pgi::Scene s = pgi::load_scene(std::string(PGI_SCENES_DIR) + "/" + name + ".toml");
        const auto n = Eigen::Index(s.x0->size());
        pgi::RowMatrix X0(6, n);
        for (Eigen::Index i = 0; i < 6; ++i)
            X0.row(i) = Eigen::Map<const Eigen::RowVectorXd>(s.x0->data(), n) * (1 - 0.05 * double(i));
        allocations_of(*s.scheme, X0, 1, 1);  // the exact phase and TBB's first use
        const long few = allocations_of(*s.scheme, X0, 1, 1), many = allocations_of(*s.scheme, X0, 50, 1);
        CHECK(few == many);
        CHECK(few > 0);  // the counter counts: the result's arrays are allocations
    }
}
