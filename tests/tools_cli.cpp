// The pgi program as a user and a script meet it: exit codes, stdout, stderr, JSON contract.
#include "poisson/hamilton_jacobi.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

using namespace pgi;
namespace fs = std::filesystem;

namespace {

struct Run {
    int exit_code;
    std::string out, err;
};

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// Runs the pgi binary with the arguments (single-quoted for the shell).
Run pgi_run(const std::vector<std::string>& args) {
    fs::path err = fs::temp_directory_path() / ("pgi_test_stderr_" + std::to_string(::getpid()));
    std::string cmd = std::string("'") + PGI_BINARY + "'";
    for (const auto& a : args) cmd += " '" + a + "'";
    cmd += " 2>'" + err.string() + "'";
    Run r{};
    FILE* pipe = ::popen(cmd.c_str(), "r");
    REQUIRE(pipe != nullptr);
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
    int status = ::pclose(pipe);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.err = slurp(err);
    fs::remove(err);
    return r;
}

std::string expected_message(const fs::path& scene) {
    std::ifstream in(scene);
    std::string first;
    std::getline(in, first);
    const std::string tag = "# expect: ";
    REQUIRE(first.rfind(tag, 0) == 0);
    return first.substr(tag.size());
}

}  // namespace

TEST_CASE("cli: every bad scene exits 2 with a message naming file, key and problem, and nothing on stdout") {
    std::size_t count = 0;
    for (const auto& entry : fs::directory_iterator(fs::path(PGI_SCENES_DIR) / "../../tests/bad_scenes")) {
        const std::string file = entry.path().string();
        for (const std::string command : {"terms", "check"}) {
            CAPTURE(file);
            CAPTURE(command);
            Run r = pgi_run({command, file});
            const std::string expect = expected_message(entry.path());
            CHECK(r.exit_code == 2);
            if (command == "terms") CHECK(r.out.empty());
            CHECK_MESSAGE(r.err.find("pgi: " + file + ": ") == 0, r.err);
            if (command == "terms" || r.out.empty())  // check prints its report for failed verdicts instead
                CHECK_MESSAGE(r.err.find(expect) != std::string::npos, r.err);
            else
                CHECK_MESSAGE(r.out.find("FAIL") != std::string::npos, r.out);
        }
        ++count;
    }
    CHECK(count >= 40);
}

TEST_CASE("cli: an unreadable file and bad flags exit 2") {
    Run missing = pgi_run({"terms", "/nonexistent/scene.toml"});
    CHECK(missing.exit_code == 2);
    CHECK(missing.out.empty());
    CHECK(missing.err == "pgi: /nonexistent/scene.toml: cannot read the file (No such file or directory)\n");
    const std::string rb = test::scene_path("rigid_body");
    Run order = pgi_run({"terms", rb, "--order", "0"});
    CHECK(order.exit_code == 2);
    CHECK(order.err == "pgi: " + rb + ": --order: the order k must be at least 1, got 0\n");
    Run order_text = pgi_run({"terms", rb, "--order", "4x"});
    CHECK(order_text.exit_code == 2);
    CHECK(order_text.err == "pgi: " + rb + ": --order: '4x' is not an integer\n");
    Run dt = pgi_run({"terms", rb, "--dt", "1/0"});
    CHECK(dt.exit_code == 2);
    CHECK(dt.err == "pgi: " + rb + ": --dt: '1/0' is not a number (zero denominator)\n");
    Run x0 = pgi_run({"terms", rb, "--x0", "1,2"});
    CHECK(x0.exit_code == 2);
    CHECK(x0.err == "pgi: " + rb + ": --x0: has 2 values for 3 coordinates\n");
    Run x0nan = pgi_run({"terms", rb, "--x0", "1,nan,2"});
    CHECK(x0nan.exit_code == 2);
    CHECK(x0nan.out.empty());
    Run unknown_flag = pgi_run({"terms", rb, "--frobnicate"});
    CHECK(unknown_flag.exit_code == 2);
    CHECK(unknown_flag.out.empty());
    Run no_command = pgi_run({});
    CHECK(no_command.exit_code == 2);
}

TEST_CASE("cli: terms --json follows the contract and equals the library's S_1..S_k") {
    const std::string rb = test::scene_path("rigid_body");
    Run r = pgi_run({"terms", rb, "--order", "5", "--json"});
    REQUIRE(r.exit_code == 0);
    CHECK(r.err.empty());
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["coordinates"] == nlohmann::json({"x1", "x2", "x3"}));
    CHECK(j["class"] == "linear");
    CHECK(j["realisation"] == "lie-poisson");
    Scene s = test::bundled("rigid_body");
    auto S = hamilton_jacobi_terms(s.phase_space(), build_realisation(s.pi, RealisationChoice::automatic, 4), s.H, 5);
    REQUIRE(j["S"].size() == 5);
    for (std::size_t i = 0; i < 5; ++i) CHECK(s.phase_space().parse(j["S"][i].get<std::string>()) == S[i]);
    // --realisation overrides the scene: radial gives the same terms for a linear structure
    Run radial = pgi_run({"terms", rb, "--order", "5", "--realisation", "radial", "--json"});
    auto jr = nlohmann::json::parse(radial.out);
    CHECK(jr["realisation"] == "radial");
    CHECK(jr["S"] == j["S"]);
}

TEST_CASE("cli: realisation --json prints alpha and beta in the momenta p_<coordinate>") {
    Run r = pgi_run({"realisation", test::scene_path("harmonic_oscillator"), "--degree", "3", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["momenta"] == nlohmann::json({"p_q", "p_p"}));
    CHECK(j["alpha"] == nlohmann::json({"q - 1/2*p_p", "p + 1/2*p_q"}));
    CHECK(j["beta"] == nlohmann::json({"q + 1/2*p_p", "p - 1/2*p_q"}));
    CHECK(j["degree"] == 3);
}

TEST_CASE("cli: check passes on every bundled scene and reports a failing Jacobi triple") {
    for (const auto& name : test::bundled_names()) {
        CAPTURE(name);
        Run r = pgi_run({"check", test::scene_path(name), "--json"});
        CHECK(r.exit_code == 0);
        auto j = nlohmann::json::parse(r.out);
        CHECK(j["ok"] == true);
        CHECK(j["jacobi"]["holds"] == true);
        CHECK(j["realisation"]["holds"] == true);
    }
    const std::string bad = (fs::path(PGI_SCENES_DIR) / "../../tests/bad_scenes/jacobi_failure.toml").string();
    Run r = pgi_run({"check", bad, "--json"});
    CHECK(r.exit_code == 2);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["jacobi"]["holds"] == false);
    CHECK(j["jacobi"]["triple"] == nlohmann::json({"x1", "x2", "x3"}));
    CHECK(j["jacobi"]["jacobiator"] == "x1*x2");
}
