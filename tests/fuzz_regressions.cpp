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

// toml++ reads (and frees) a dotted key by recursion, a level a segment: a key of 40000 segments overflowed the stack.
TEST_CASE("scene reader: a key nested deeper than 64 levels is refused with its line, before the TOML parser") {
    const auto key = [](std::size_t segments) {
        std::string k = "a";
        for (std::size_t i = 1; i < segments; ++i) k += ".a";
        return k;
    };
    const auto problem = [](const std::string& text) {
        try {
            (void)pgi::parse_scene(text, "deep.toml");
        } catch (const pgi::SceneError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    CHECK(problem(std::string("name = \"x\"\n") + key(40000) + " = 1\n") ==
          "deep.toml: a key nested deeper than 64 levels at line 2");
    CHECK(problem(std::string("[") + key(40000) + "]\n") == "deep.toml: a key nested deeper than 64 levels at line 1");
    // 64 levels reach the reader, which names the unknown key; dots in strings, comments and numbers are no key's
    CHECK(problem(key(64) + " = 1\n").find("unknown key") != std::string::npos);
    const std::string dots(200, '.');
    std::string text = "name = \"";
    for (const std::string& piece : {dots, std::string("\" # "), dots, std::string("\nx = '''\n"), dots,
                                     std::string("\n'''\n"), key(64), std::string(" = [0.5, 1.5]\n")})
        text += piece;
    CHECK(problem(text).find("unknown key") != std::string::npos);
}
