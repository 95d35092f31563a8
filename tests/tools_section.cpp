// pgi section: the crossings report, its CSV, and refused events.
#include "tools/section.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <sys/wait.h>
#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;

TEST_CASE("tools_section: the oscillator's falling crossings of q = 0, stopped after two, in the CSV") {
    SceneOverrides o;
    o.order = "4";
    o.dt = "1/20";
    o.t_end = "20";
    const Scene s = load_scene(test::scene_path("harmonic_oscillator"), o);
    const fs::path csv = fs::temp_directory_path() / ("pgi_section_" + std::to_string(::getpid()) + ".csv");
    SectionOptions so;
    so.event = "q";
    so.direction = -1;
    so.max_crossings = 2;
    so.csv = csv;
    const auto r = section_report(s, so);
    REQUIRE(r["count"] == 2);
    CHECK(r["method_order"] == 4);
    const double pi = std::numbers::pi;
    // order 4 at dt = 1/20: the phase drifts by ~5e-8 per unit time (measured 8e-8 at t = 1.6, 4e-7 at 7.9)
    CHECK(std::abs(r["crossings"][0]["t"].get<double>() - pi / 2) < 1e-5);
    CHECK(std::abs(r["crossings"][1]["t"].get<double>() - 5 * pi / 2) < 1e-5);
    CHECK(r["crossings"][1]["x"][1].get<double>() < 0);  // falling: p = -sin t < 0
    CHECK(r["t"].get<double>() == r["crossings"][1]["t"].get<double>());
    std::ifstream in(csv);
    std::string header, row;
    std::getline(in, header);
    CHECK(header == "t,q,p");
    int rows = 0;
    while (std::getline(in, row)) {
        std::istringstream fields(row);
        std::string t;
        std::getline(fields, t, ',');
        CHECK(std::stod(t) == r["crossings"][rows]["t"].get<double>());  // shortest round-trip form
        ++rows;
    }
    CHECK(rows == 2);
    fs::remove(csv);
}

TEST_CASE("tools_section: a bad event exits 2 with its message and writes no CSV") {
    const fs::path csv = fs::temp_directory_path() / ("pgi_section_bad_" + std::to_string(::getpid()) + ".csv");
    const fs::path err = fs::temp_directory_path() / ("pgi_section_err_" + std::to_string(::getpid()));
    const std::string cmd = std::string("'") + PGI_BINARY + "' section '" + test::scene_path("harmonic_oscillator") +
                            "' --event 'q + w' --csv '" + csv.string() + "' >/dev/null 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 2);
    std::ifstream in(err);
    std::string message;
    std::getline(in, message);
    CHECK(message.find("event 1: malformed polynomial 'q + w': unknown variable 'w'") != std::string::npos);
    CHECK(!fs::exists(csv));
    fs::remove(err);
}
