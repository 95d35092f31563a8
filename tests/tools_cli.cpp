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

TEST_CASE("cli: step --json gives the state after one step, the Newton iterations and the residual") {
    const std::string lv = test::scene_path("lotka_volterra");
    Run r = pgi_run({"step", lv, "--x0", "1,2,1/2", "--dt", "1/20", "--order", "4", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    REQUIRE(j["x"].size() == 3);
    CHECK(j["newton_iterations"].get<int>() >= 1);
    CHECK(j["newton_iterations"].get<int>() <= 2);
    CHECK(j["residual"].get<double>() < 1e-12);
    // the Casimir x1 x2 x3 = 1 is kept by the step
    CHECK(j["x"][0].get<double>() * j["x"][1].get<double>() * j["x"][2].get<double>() == doctest::Approx(1.0).epsilon(1e-14));
    Run nan = pgi_run({"step", lv, "--x0", "1,inf,2", "--json"});
    CHECK(nan.exit_code == 2);
    CHECK(nan.out.empty());
}

TEST_CASE("cli: integrate --json --csv writes the summary and the trajectory") {
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_" + std::to_string(::getpid()) + ".csv");
    Run r = pgi_run({"integrate", test::scene_path("nambu"), "--t-end", "10", "--csv", csv.string(), "--every", "50", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["steps"] == 200);
    CHECK(j["t"].get<double>() == doctest::Approx(10.0));
    CHECK(j["casimir_error_max"][0].get<double>() <= 1e-13);
    CHECK(j["energy_error_max"].get<double>() < 1e-6);
    CHECK(j["newton_iterations_mean"].get<double>() <= 2.0);
    CHECK(j["wall_seconds"].get<double>() >= 0.0);
    std::string text = slurp(csv);
    CHECK(text.rfind("t,x1,x2,x3,H,C1\n", 0) == 0);
    CHECK(std::count(text.begin(), text.end(), '\n') == 1 + 5);  // header, t = 0, 2.5, 5, 7.5, 10
    fs::remove(csv);
}

TEST_CASE("cli: a step that does not converge stops the run with exit 3, naming step, t and residual; the CSV is kept, marked") {
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_fail_" + std::to_string(::getpid()) + ".csv");
    Run r = pgi_run({"integrate", test::scene_path("rigid_body"), "--dt", "5", "--order", "2", "--csv", csv.string()});
    CHECK(r.exit_code == 3);
    CHECK(r.out.empty());
    CHECK(r.err.rfind("pgi: " + test::scene_path("rigid_body") + ": step ", 0) == 0);
    CHECK_MESSAGE(r.err.find(") failed: Newton did not converge after 40 Newton iterations, residual ") != std::string::npos, r.err);
    std::string text = slurp(csv);
    CHECK(text.rfind("t,x1,x2,x3,H,C1\n0,", 0) == 0);
    CHECK(text.find("# INCOMPLETE: step ") != std::string::npos);
    fs::remove(csv);
}

TEST_CASE("cli: an output path in a missing directory exits 2 and writes nothing") {
    Run r = pgi_run({"integrate", test::scene_path("rigid_body"), "--csv", "/nonexistent-dir/out.csv"});
    CHECK(r.exit_code == 2);
    CHECK(r.out.empty());
    CHECK(r.err.find("/nonexistent-dir/out.csv: cannot write: directory '/nonexistent-dir' does not exist") != std::string::npos);
    CHECK_FALSE(fs::exists("/nonexistent-dir/out.csv"));
}

TEST_CASE("cli: step and integrate need x0 and t_end, and say which is missing") {
    const fs::path scene = fs::temp_directory_path() / ("pgi_test_norun_" + std::to_string(::getpid()) + ".toml");
    {
        std::ofstream out(scene);
        out << "name = \"no run\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = \"1\"\n[hamiltonian]\nH = \"q^2/2 + p^2/2\"\n";
    }
    Run step = pgi_run({"step", scene.string(), "--json"});
    CHECK(step.exit_code == 2);
    CHECK(step.err == "pgi: " + scene.string() + ": run.x0: missing: give [run] x0 or --x0\n");
    Run integrate = pgi_run({"integrate", scene.string(), "--x0", "1,0"});
    CHECK(integrate.exit_code == 2);
    CHECK(integrate.err == "pgi: " + scene.string() + ": run.t_end: missing: give [run] t_end or --t-end\n");
    Run ok = pgi_run({"integrate", scene.string(), "--x0", "1,0", "--t-end", "1", "--json"});
    CHECK(ok.exit_code == 0);
    fs::remove(scene);
}

TEST_CASE("cli: magnus --json prints M_0..M_m of the scene's [magnus] h; without one it exits 2") {
    Run r = pgi_run({"magnus", test::scene_path("kahan_lotka_volterra"), "--upto", "5", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["coordinates"] == nlohmann::json({"x1", "x2", "x3"}));
    REQUIRE(j["magnus"].size() == 6);
    Scene s = test::bundled("kahan_lotka_volterra");
    const auto& M = s.phase_space();
    CHECK(j["magnus"][0] == "0");
    CHECK(M.parse(j["magnus"][1].get<std::string>()) == s.H);
    CHECK(M.parse(j["magnus"][3].get<std::string>()) == Rational(1, 36) * pow(s.H, 3));
    CHECK(M.parse(j["magnus"][5].get<std::string>()) == Rational(1, 400) * pow(s.H, 5));
    Run missing = pgi_run({"magnus", test::scene_path("rigid_body")});
    CHECK(missing.exit_code == 2);
    CHECK(missing.err == "pgi: " + test::scene_path("rigid_body") + ": magnus.h: missing: the scene has no [magnus] h\n");
}

TEST_CASE("cli: modified --json prints H_0..H_m of the order-k scheme") {
    Run r = pgi_run({"modified", test::scene_path("harmonic_oscillator"), "--order", "1", "--upto", "4", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["order"] == 1);
    CHECK(j["modified"] == nlohmann::json({"1/2*q^2 + 1/2*p^2", "0", "-1/24*q^2 - 1/24*p^2", "0", "1/160*q^2 + 1/160*p^2"}));
}

TEST_CASE("cli: report writes Markdown, JSON and LaTeX atomically, and the LaTeX compiles with pdflatex") {
    const fs::path dir = fs::temp_directory_path() / ("pgi_test_report_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string scene = test::scene_path("rigid_body");
    Run md = pgi_run({"report", scene, "--order", "2", "--out", (dir / "r.md").string()});
    REQUIRE(md.exit_code == 0);
    CHECK(md.out.empty());
    const std::string text = slurp(dir / "r.md");
    for (const char* section : {"# free rigid body", "## Poisson structure", "## Integrator", "## Modified Hamiltonian", "## Numerical check"})
        CHECK_MESSAGE(text.find(section) != std::string::npos, section);
    CHECK(text.find("- `H_2 = -1/64*x1^2*x2^2 - 1/24*x1^2*x3^2 - 1/192*x2^2*x3^2`") != std::string::npos);
    Run js = pgi_run({"report", scene, "--format", "json"});
    REQUIRE(js.exit_code == 0);
    auto j = nlohmann::json::parse(js.out);
    CHECK(j["run"]["modified_energy_error_max"].get<double>() < j["run"]["energy_error_max"].get<double>());
    CHECK(j["check"]["ok"] == true);
    Run tex = pgi_run({"report", scene, "--format", "latex", "--out", (dir / "r.tex").string()});
    REQUIRE(tex.exit_code == 0);
    const int rc = std::system(("cd '" + dir.string() + "' && pdflatex -interaction=nonstopmode -halt-on-error r.tex > r.log 2>&1").c_str());
    CHECK_MESSAGE(rc == 0, slurp(dir / "r.log"));
    CHECK(fs::exists(dir / "r.pdf"));
    Run bad = pgi_run({"report", scene, "--out", "/nonexistent-dir/r.md"});
    CHECK(bad.exit_code == 2);
    CHECK(bad.out.empty());
    Run bad_format = pgi_run({"report", scene, "--format", "docx"});
    CHECK(bad_format.exit_code == 2);
    fs::remove_all(dir);
}

TEST_CASE("cli: resource guards stop the exact phase and oversized output before they start, with exit 2") {
    const std::string nambu = test::scene_path("nambu");
    Run terms = pgi_run({"integrate", nambu, "--dt", "1/2", "--max-terms", "20000", "--json"});
    CHECK(terms.exit_code == 4);  // budget exceeded (the shared exit codes)
    CHECK(terms.out.empty());
    CHECK_MESSAGE(terms.err.find("exact phase stopped: radial realisation, terms of degree ") != std::string::npos, terms.err);
    CHECK(terms.err.find("above the limit of 20000 (raise it with --max-terms)") != std::string::npos);
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_big_" + std::to_string(::getpid()) + ".csv");
    Run big = pgi_run({"integrate", nambu, "--t-end", "1e6", "--csv", csv.string(), "--max-csv-mb", "10"});
    CHECK(big.exit_code == 2);
    CHECK_MESSAGE(big.err.find("--csv: the trajectory would take about ") != std::string::npos, big.err);
    CHECK_FALSE(fs::exists(csv));
}

TEST_CASE("cli: a coefficient beyond the double range is refused, not turned into infinity") {
    const fs::path scene = fs::temp_directory_path() / ("pgi_test_huge_" + std::to_string(::getpid()) + ".toml");
    {
        std::ofstream out(scene);
        out << "name = \"huge\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = \"1\"\n[hamiltonian]\nH = \"10^400*q^2 + p^2\"\n"
               "[run]\nx0 = [1.0, 0.0]\nt_end = 1\n";
    }
    Run r = pgi_run({"integrate", scene.string()});
    CHECK(r.exit_code == 2);
    CHECK_MESSAGE(r.err.find("is beyond the double range") != std::string::npos, r.err);
    fs::remove(scene);
}

TEST_CASE("cli: no bad scene leaves an output file behind") {
    const fs::path dir = fs::temp_directory_path() / ("pgi_test_noout_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    for (const auto& entry : fs::directory_iterator(fs::path(PGI_SCENES_DIR) / "../../tests/bad_scenes")) {
        CAPTURE(entry.path().string());
        Run csv = pgi_run({"integrate", entry.path().string(), "--csv", (dir / "out.csv").string()});
        CHECK(csv.exit_code == 2);
        Run report = pgi_run({"report", entry.path().string(), "--out", (dir / "out.md").string()});
        CHECK(report.exit_code == 2);
        CHECK(fs::is_empty(dir));
    }
    fs::remove_all(dir);
}
