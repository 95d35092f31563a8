// The report side of pgi: splitting reports from scenes, LaTeX that fits the page (pdflatex when installed),
// plots of a run.
#include "tools/commands.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

using namespace pgi;

TEST_CASE("splitting_report: Henon-Heiles' Strang series and its measured order of conservation") {
    Scene s = test::bundled("henon_heiles");
    auto r = splitting_report(s, SplittingMethod::strang, 2);
    REQUIRE(r["modified"].size() == 3);
    CHECK(r["modified"][1][0] == "0");
    CHECK(r["run"]["modified_order_expected"] == 4);
    // H through dt^2 kept to O(dt^4): doubling the steps divides the drift by 2^4 up to O(dt) = 10%
    CHECK(std::abs(r["run"]["modified_order_measured"].get<double>() - 4) < 0.3);
    CHECK(std::abs(r["run"]["energy_order_measured"].get<double>() - 2) < 0.3);
}

TEST_CASE("splitting_report: refuses a scene without [splitting], says why a non-polynomial flow is not run") {
    CHECK_THROWS_AS(splitting_report(test::bundled("rigid_body"), SplittingMethod::strang, 2), SceneError);
    Scene s = test::bundled("rigid_body");
    s.splitting_A = s.phase_space().parse("x1^2/2");  // the flow of x1^2/2 on so(3)* is a rotation
    auto r = splitting_report(s, SplittingMethod::lie_trotter, 2);
    CHECK(r["run"].contains("skipped"));
    CHECK(r["modified"].size() == 3);
}
