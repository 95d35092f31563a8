// Every input in tests/fuzz/regressions/ (crashes the fuzzer found, and hostile inputs of issue 11) runs
// through the fuzz target's pipeline and ends in a documented outcome, never an escaping exception.
#include "tests/fuzz/pipeline.hpp"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

TEST_CASE("fuzz: every regression seed ends in a documented outcome through the whole pipeline") {
    const fs::path dir = fs::path(PGI_SCENES_DIR) / ".." / ".." / "tests" / "fuzz" / "regressions";
    std::size_t seen = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (!entry.is_regular_file() || entry.path().extension() == ".md") continue;
        std::ifstream in(entry.path(), std::ios::binary);
        std::stringstream bytes;
        bytes << in.rdbuf();
        CAPTURE(entry.path().filename().string());
        CHECK_NOTHROW((void)pgi::fuzz::run_pipeline(bytes.str()));
        CHECK_NOTHROW((void)pgi::fuzz::run_parser(bytes.str()));
        CHECK_NOTHROW((void)pgi::fuzz::run_states(bytes.str()));
        ++seen;
    }
    CHECK(seen > 0);
}
