// The pgi program as a user and a script meet it: exit codes, stdout, stderr, JSON contract.
#include "poisson/hamilton_jacobi.hpp"
#include "scheme/version.hpp"
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;
using test::slurp;

namespace {

struct Run {
    int exit_code;
    std::string out, err;
};

// Runs the pgi binary with the arguments (single-quoted for the shell), after the shell assignments env.
Run pgi_run(const std::vector<std::string>& args, const std::string& env = "") {
    fs::path err = fs::temp_directory_path() / ("pgi_test_stderr_" + std::to_string(::getpid()));
    std::string cmd = env + " '" + PGI_BINARY + "'";
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

// A scene file written for one test, removed at the end of it.
struct TempScene {
    fs::path path;
    TempScene(const std::string& tag, const std::string& text)
        : path(fs::temp_directory_path() / ("pgi_test_" + tag + "_" + std::to_string(::getpid()) + ".toml")) {
        std::ofstream(path) << text;
    }
    ~TempScene() { fs::remove(path); }
};

// A fresh empty directory, removed with what is in it.
struct TempDir {
    fs::path path;
    explicit TempDir(const std::string& tag)
        : path(fs::temp_directory_path() / ("pgi_test_dir_" + tag + "_" + std::to_string(::getpid()))) {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() { fs::remove_all(path); }
};

// The exit status of a shell command (run through sh), -1 if it died of a signal.
int shell(const std::string& cmd) {
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
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
    Run dt = pgi_run({"step", rb, "--dt", "1/0"});
    CHECK(dt.exit_code == 2);
    CHECK(dt.err == "pgi: " + rb + ": --dt: '1/0' is not a number (zero denominator)\n");
    Run x0 = pgi_run({"step", rb, "--x0", "1,2"});
    CHECK(x0.exit_code == 2);
    CHECK(x0.err == "pgi: " + rb + ": --x0: has 2 values for 3 coordinates\n");
    Run x0nan = pgi_run({"step", rb, "--x0", "1,nan,2"});
    CHECK(x0nan.exit_code == 2);
    CHECK(x0nan.out.empty());
    // options belong to the subcommands that read them: terms reads neither dt nor x0, run prints text only
    for (std::vector<std::string> args : {std::vector<std::string>{"terms", rb, "--dt", "1/10"},
                                          {"terms", rb, "--x0", "1,2,3"},
                                          {"magnus", rb, "--order", "3"},
                                          {"run", rb, "--json"},
                                          {"report", rb, "--json"}}) {
        Run r = pgi_run(args);
        CHECK(r.exit_code == 2);
        CHECK(r.out.empty());
        CHECK(r.err.find("not expected") != std::string::npos);
    }
    Run unknown_flag = pgi_run({"terms", rb, "--frobnicate"});
    CHECK(unknown_flag.exit_code == 2);
    CHECK(unknown_flag.out.empty());
    Run no_command = pgi_run({});
    CHECK(no_command.exit_code == 2);
}

TEST_CASE("cli: --version names the version and the allocator the program runs on") {
    // mimalloc (and its version) unless the build turned it off (PGI_MIMALLOC, sanitizers): a link that lost it shows
    // here
    Run v = pgi_run({"--version"});
    CHECK(v.exit_code == 0);
    CHECK_MESSAGE(v.out.starts_with("pgi " + std::string(pgi::version()) + " (allocator: " + PGI_PROGRAM_ALLOCATOR),
                  v.out);
    CHECK(v.out.ends_with(")\n"));
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

TEST_CASE("cli: decimal coefficients in a scene are exact rationals: the same terms as the fractions") {
    const std::string head =
        "name = \"decimals\"\ncoordinates = [\"x1\", \"x2\", \"x3\"]\n[brackets]\n"
        "\"x1,x2\" = \"-x3\"\n\"x2,x3\" = \"-x1\"\n\"x3,x1\" = \"-x2\"\n[hamiltonian]\n";
    TempScene decimals("decimals", head +
                                       "H = \"0.25*x1^2 + 0.5*x2^2 + 7.5e-1*x3^2\"\n"
                                       "casimirs = [\"1.0*x1^2 + 10e-1*x2^2 + 0.1e1*x3^2\"]\n");
    TempScene fractions("fractions", head +
                                         "H = \"1/4*x1^2 + 1/2*x2^2 + 3/4*x3^2\"\n"
                                         "casimirs = [\"x1^2 + x2^2 + x3^2\"]\n");
    Run d = pgi_run({"terms", decimals.path.string(), "--order", "3", "--json"});
    Run f = pgi_run({"terms", fractions.path.string(), "--order", "3", "--json"});
    REQUIRE(d.exit_code == 0);
    REQUIRE(f.exit_code == 0);
    CHECK(nlohmann::json::parse(d.out)["S"] == nlohmann::json::parse(f.out)["S"]);
    Run c = pgi_run({"check", decimals.path.string()});
    CHECK(c.exit_code == 0);
    CHECK_MESSAGE(c.out.find("Casimir x1^2 + x2^2 + x3^2: holds") != std::string::npos, c.out);
}

TEST_CASE("cli: the run's text names each Casimir whose error it prints") {
    Run one = pgi_run({"integrate", test::scene_path("rigid_body"), "--t-end", "1"});
    REQUIRE(one.exit_code == 0);
    CHECK_MESSAGE(one.out.find("  max relative error of Casimir x1^2 + x2^2 + x3^2: ") != std::string::npos, one.out);
    Run two = pgi_run({"run", test::scene_path("volterra_chain"), "--t-end", "1"});
    REQUIRE(two.exit_code == 0);
    const auto first = two.out.find("  max relative error of Casimir C1 = x1*x3*x5: ");
    const auto second = two.out.find("  max relative error of Casimir C2 = x2*x4*x6: ");
    CHECK_MESSAGE((first != std::string::npos && second != std::string::npos && first < second), two.out);
    Run json = pgi_run({"integrate", test::scene_path("volterra_chain"), "--t-end", "1", "--json"});
    CHECK(nlohmann::json::parse(json.out)["casimirs"] == nlohmann::json({"x1*x3*x5", "x2*x4*x6"}));
    TempDir dir("casimir_report");
    const fs::path md = dir.path / "r.md";
    REQUIRE(pgi_run({"report", test::scene_path("rigid_body"), "--order", "2", "--out", md.string()}).exit_code == 0);
    CHECK_MESSAGE(slurp(md).find(", of the Casimir `x1^2 + x2^2 + x3^2` ") != std::string::npos, slurp(md));
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
    CHECK(j["x"][0].get<double>() * j["x"][1].get<double>() * j["x"][2].get<double>() ==
          doctest::Approx(1.0).epsilon(1e-14));
    Run nan = pgi_run({"step", lv, "--x0", "1,inf,2", "--json"});
    CHECK(nan.exit_code == 2);
    CHECK(nan.out.empty());
}

TEST_CASE("cli: a run that ends with the energy off by more than a tenth says so on stderr and in JSON, exit 0") {
    // k = 1 (the implicit-midpoint-like order 2) on the rigid body: every step solves its equation, but at dt = 3 the
    // relative energy error reaches 0.13 (0.05 at dt = 2, 0.002 at dt = 0.5: the method's dt^2)
    const std::string rb = test::scene_path("rigid_body");
    Run coarse = pgi_run({"integrate", rb, "--order", "1", "--dt", "3", "--json"});
    REQUIRE(coarse.exit_code == 0);
    auto j = nlohmann::json::parse(coarse.out);
    CHECK(j["energy_error_max"].get<double>() > 0.1);
    CHECK(j["energy_warning"] == true);
    CHECK(coarse.err.find("warning: the relative energy error reached") != std::string::npos);
    CHECK(coarse.err.find("reduce dt or raise the order") != std::string::npos);
    Run fine = pgi_run({"integrate", rb, "--order", "1", "--dt", "1/2", "--json"});
    REQUIRE(fine.exit_code == 0);
    j = nlohmann::json::parse(fine.out);
    CHECK(j["energy_error_max"].get<double>() < 0.1);
    CHECK(j["energy_warning"] == false);
    CHECK(fine.err.find("energy error") == std::string::npos);
}

// issue 11.9
TEST_CASE("cli: integrate --json --csv writes the summary and the trajectory") {
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_" + std::to_string(::getpid()) + ".csv");
    Run r = pgi_run(
        {"integrate", test::scene_path("nambu"), "--t-end", "10", "--csv", csv.string(), "--every", "50", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["steps"] == 200);
    CHECK(j["t"].get<double>() == doctest::Approx(10.0));
    CHECK(j["casimir_error_max"][0].get<double>() <= 1e-13);
    CHECK(j["energy_error_max"].get<double>() < 1e-6);
    CHECK(j["newton_iterations_mean"].get<double>() <= 2.0);
    // issue 11.9: was wall_seconds >= 0, which cannot fail; the per-step time is the wall time over the steps
    CHECK(j["ns_per_step"].get<double>() ==
          doctest::Approx(j["wall_seconds"].get<double>() / 200 * 1e9).epsilon(1e-12));
    CHECK(j["status"] == "ok");
    std::string text = slurp(csv);
    CHECK(text.rfind("t,x1,x2,x3,H,C1\n", 0) == 0);
    CHECK(std::count(text.begin(), text.end(), '\n') == 1 + 5);  // header, t = 0, 2.5, 5, 7.5, 10
    fs::remove(csv);
}

TEST_CASE(
    "cli: a step that does not converge stops the run with exit 3, naming step, t and residual; the CSV is kept, "
    "marked") {
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_fail_" + std::to_string(::getpid()) + ".csv");
    Run r = pgi_run({"integrate", test::scene_path("rigid_body"), "--dt", "5", "--order", "2", "--csv", csv.string()});
    CHECK(r.exit_code == 3);
    CHECK(r.out.empty());
    CHECK(r.err.rfind("pgi: " + test::scene_path("rigid_body") + ": step ", 0) == 0);
    // the iteration count depends on the Newton budget and its backtracking: not pinned
    CHECK_MESSAGE(r.err.find(") failed: Newton did not converge after ") != std::string::npos, r.err);
    CHECK_MESSAGE(r.err.find(" Newton iterations, residual ") != std::string::npos, r.err);
    std::string text = slurp(csv);
    CHECK(text.rfind("t,x1,x2,x3,H,C1\n0,", 0) == 0);
    CHECK(text.find("# INCOMPLETE: step ") != std::string::npos);
    fs::remove(csv);
}

TEST_CASE("cli: an output path in a missing directory exits 2 and writes nothing") {
    Run r = pgi_run({"integrate", test::scene_path("rigid_body"), "--csv", "/nonexistent-dir/out.csv"});
    CHECK(r.exit_code == 2);
    CHECK(r.out.empty());
    CHECK(r.err.find("/nonexistent-dir/out.csv: cannot write: directory '/nonexistent-dir' does not exist") !=
          std::string::npos);
    CHECK_FALSE(fs::exists("/nonexistent-dir/out.csv"));
}

TEST_CASE("cli: step and integrate need x0 and t_end, and say which is missing") {
    const fs::path scene = fs::temp_directory_path() / ("pgi_test_norun_" + std::to_string(::getpid()) + ".toml");
    {
        std::ofstream out(scene);
        out << "name = \"no run\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = \"1\"\n[hamiltonian]\nH = "
               "\"q^2/2 + p^2/2\"\n";
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
    CHECK(missing.err ==
          "pgi: " + test::scene_path("rigid_body") + ": magnus.h: missing: the scene has no [magnus] h\n");
}

TEST_CASE("cli: modified --json prints H_0..H_m of the order-k scheme") {
    Run r = pgi_run({"modified", test::scene_path("harmonic_oscillator"), "--order", "1", "--upto", "4", "--json"});
    REQUIRE(r.exit_code == 0);
    auto j = nlohmann::json::parse(r.out);
    CHECK(j["order"] == 1);
    CHECK(j["modified"] ==
          nlohmann::json({"1/2*q^2 + 1/2*p^2", "0", "-1/24*q^2 - 1/24*p^2", "0", "1/160*q^2 + 1/160*p^2"}));
}

TEST_CASE("cli: report writes Markdown, JSON and LaTeX atomically, and the LaTeX compiles with pdflatex") {
    const fs::path dir = fs::temp_directory_path() / ("pgi_test_report_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string scene = test::scene_path("rigid_body");
    Run md = pgi_run({"report", scene, "--order", "2", "--out", (dir / "r.md").string()});
    REQUIRE(md.exit_code == 0);
    CHECK(md.out.empty());
    const std::string text = slurp(dir / "r.md");
    for (const char* section : {"# free rigid body", "## Poisson structure", "## Integrator", "## Modified Hamiltonian",
                                "## Numerical check"})
        CHECK_MESSAGE(text.find(section) != std::string::npos, section);
    CHECK(text.find("- `H_2 = -1/64*x1^2*x2^2 - 1/24*x1^2*x3^2 - 1/192*x2^2*x3^2`") != std::string::npos);
    Run js = pgi_run({"report", scene, "--format", "json"});
    REQUIRE(js.exit_code == 0);
    auto j = nlohmann::json::parse(js.out);
    CHECK(j["run"]["modified_energy_error_max"].get<double>() < j["run"]["energy_error_max"].get<double>());
    CHECK(j["check"]["ok"] == true);
    Run tex = pgi_run({"report", scene, "--format", "latex", "--out", (dir / "r.tex").string()});
    REQUIRE(tex.exit_code == 0);
    const int rc = std::system(
        ("cd '" + dir.string() + "' && pdflatex -interaction=nonstopmode -halt-on-error r.tex > r.log 2>&1").c_str());
    CHECK_MESSAGE(rc == 0, slurp(dir / "r.log"));
    CHECK(fs::exists(dir / "r.pdf"));
    Run bad = pgi_run({"report", scene, "--out", "/nonexistent-dir/r.md"});
    CHECK(bad.exit_code == 2);
    CHECK(bad.out.empty());
    Run bad_format = pgi_run({"report", scene, "--format", "docx"});
    CHECK(bad_format.exit_code == 2);
    fs::remove_all(dir);
}

TEST_CASE("cli: resource guards stop the exact phase and oversized output before they start, with exit 4 (a budget)") {
    const std::string nambu = test::scene_path("nambu");
    Run terms = pgi_run({"integrate", nambu, "--dt", "1/2", "--max-terms", "20000", "--json"});
    CHECK(terms.exit_code == 4);  // budget exceeded (the shared exit codes)
    CHECK(terms.out.empty());
    CHECK_MESSAGE(terms.err.find("exact phase stopped: radial realisation, terms of degree ") != std::string::npos,
                  terms.err);
    CHECK(terms.err.find("above the limit of 20000 (raise it with --max-terms or max_terms)") != std::string::npos);
    const fs::path csv = fs::temp_directory_path() / ("pgi_test_big_" + std::to_string(::getpid()) + ".csv");
    Run big = pgi_run({"integrate", nambu, "--t-end", "1e6", "--csv", csv.string(), "--max-csv-mb", "10"});
    CHECK(big.exit_code == 4);
    CHECK_MESSAGE(big.err.find("--csv: the trajectory would take about ") != std::string::npos, big.err);
    CHECK_FALSE(fs::exists(csv));
}

TEST_CASE("cli: a coefficient beyond the double range is refused, not turned into infinity") {
    const fs::path scene = fs::temp_directory_path() / ("pgi_test_huge_" + std::to_string(::getpid()) + ".toml");
    {
        std::ofstream out(scene);
        out << "name = \"huge\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = \"1\"\n[hamiltonian]\nH = "
               "\"10^400*q^2 + p^2\"\n"
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

// issue 11.1
TEST_CASE("the step count is computed in checked arithmetic and refused above --max-steps before any work") {
    const std::string rb = test::scene_path("rigid_body");
    // t_end / dt = 1e600 steps: on 57dddde the cast to size_t gave 0 steps and exit 0
    Run huge = pgi_run({"integrate", rb, "--t-end", "1e300", "--dt", "1e-300", "--json"});
    CHECK(huge.exit_code == 4);
    CHECK(huge.out.empty());
    CHECK_MESSAGE(
        huge.err.find("above the step budget of 100000000 (raise max_steps / --max-steps") != std::string::npos,
        huge.err);
    Run run = pgi_run({"run", rb, "--t-end", "1e9"});  // 1e10 steps: refused before the check is printed
    CHECK(run.exit_code == 4);
    CHECK(run.out.empty());
    Run budget = pgi_run({"integrate", rb, "--t-end", "1", "--max-steps", "9"});
    CHECK(budget.exit_code == 4);
    CHECK_MESSAGE(budget.err.find("needs 10 steps, above the step budget of 9") != std::string::npos, budget.err);
    // report runs the scene's trajectory too: the same budget, refused before anything is written
    Run report = pgi_run({"report", rb, "--t-end", "1", "--max-steps", "9"});
    CHECK(report.exit_code == 4);
    CHECK(report.out.empty());
    CHECK_MESSAGE(report.err.find("needs 10 steps, above the step budget of 9") != std::string::npos, report.err);
    Run ok = pgi_run({"integrate", rb, "--t-end", "1", "--max-steps", "10", "--json"});
    REQUIRE(ok.exit_code == 0);
    CHECK(nlohmann::json::parse(ok.out)["steps"] == 10);
    // t_end not a whole number of steps: rounded up, and the final t says where the run ended
    Run partial = pgi_run({"integrate", rb, "--t-end", "0.25", "--json"});
    REQUIRE(partial.exit_code == 0);
    auto j = nlohmann::json::parse(partial.out);
    CHECK(j["steps"] == 3);
    CHECK(j["t"].get<double>() == 3 * 0.1);
    CHECK(j["t_end"].get<double>() == 0.25);
    Run text = pgi_run({"integrate", rb, "--t-end", "0.25"});
    CHECK_MESSAGE(
        text.out.find("t_end = 0.25 is not a whole number of steps: the last step ends at t = 0.30000000000000004") !=
            std::string::npos,
        text.out);
    // a t_end far below dt still takes one step, never zero
    Run tiny = pgi_run({"integrate", rb, "--t-end", "1e-300", "--json"});
    REQUIRE(tiny.exit_code == 0);
    CHECK(nlohmann::json::parse(tiny.out)["steps"] == 1);
}

// issue 11.2
TEST_CASE(
    "a failed step stops the run: step, t, residual and a hint on stderr; --json gives status and the last good "
    "state") {
    const std::string rb = test::scene_path("rigid_body");
    Run r = pgi_run({"integrate", rb, "--dt", "5", "--order", "2", "--json"});
    CHECK(r.exit_code == 3);
    CHECK_MESSAGE(r.err.find("residual ") != std::string::npos, r.err);
    CHECK(r.err.find("a smaller dt may help") != std::string::npos);
    CHECK(r.err.find("(the last good state is step ") != std::string::npos);
    auto j = nlohmann::json::parse(r.out);  // on 57dddde stdout was empty with --json
    CHECK(j["status"] == "step_failed");
    CHECK(j["failed_step"].get<std::size_t>() == j["steps"].get<std::size_t>() + 1);
    CHECK(j["t"].get<double>() == 5.0 * j["steps"].get<double>());
    CHECK(j["failure"].get<std::string>() ==
          r.err.substr(r.err.find(": step ") + 2, r.err.size() - r.err.find(": step ") - 3));
    // dt = 5 fails within a few steps; the last good state is a state of the run: on the Casimir's sphere
    const auto x = j["x"].get<std::vector<double>>();
    CHECK(j["steps"].get<std::size_t>() < 10);
    CHECK(std::abs(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] - 1.0) < 1e-13);
    // an invariant that is not finite stops the run (57dddde printed energy error 0 and exited 0)
    Run inf =
        pgi_run({"integrate", test::scene_path("harmonic_oscillator"), "--x0", "1e200,0", "--t-end", "1", "--json"});
    CHECK(inf.exit_code == 3);
    CHECK_MESSAGE(inf.err.find("the invariant H = inf at x0 is not finite") != std::string::npos, inf.err);
    CHECK(nlohmann::json::parse(inf.out)["status"] == "step_failed");
    Run good = pgi_run({"step", rb, "--json"});
    REQUIRE(good.exit_code == 0);
    CHECK(nlohmann::json::parse(good.out)["status"] == "ok");
}

// issue 11.5
TEST_CASE("every numeric option is one finite number in its range; lists are strict") {
    const std::string rb = test::scene_path("rigid_body"), nambu = test::scene_path("nambu");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
        {{"integrate", nambu, "--max-csv-mb", "nan", "--csv", "/tmp/pgi_never.csv"},
         "--max-csv-mb: 'nan' is not a number above 0"},
        {{"integrate", nambu, "--max-csv-mb", "inf"}, "--max-csv-mb: 'inf'"},
        {{"realisation", rb, "--degree", "1e9"}, "--degree: '1e9' is not a whole number from 0 to 100"},
        {{"realisation", rb, "--degree", "-1"}, "--degree: '-1' is not a whole number from 0 to 100"},
        {{"realisation", rb, "--degree", "18446744073709551615"}, "--degree: '18446744073709551615'"},
        {{"modified", rb, "--upto", "-1"}, "--upto: '-1' is not a whole number from 0 to 64"},
        {{"magnus", rb, "--upto", "1.5"}, "--upto: '1.5'"},
        {{"integrate", rb, "--every", "0"}, "--every: '0'"},
        {{"integrate", rb, "--every", "nan"}, "--every: 'nan'"},
        {{"terms", rb, "--max-terms", "-5"}, "--max-terms: '-5'"},
        {{"integrate", rb, "--max-steps", "0"}, "--max-steps: '0'"},
        {{"terms", rb, "--order", "1e9"}, "--order: '1e9' is not an integer"},
        {{"terms", rb, "--order", "65"}, "--order: the order k must be at most 64"},
        {{"step", rb, "--dt", "nan"}, "--dt:"},
        {{"step", rb, "--dt", "-1/10"}, "--dt: the step dt must be positive"},
        {{"integrate", rb, "--t-end", "inf"}, "--t-end:"},
        {{"step", rb, "--x0", "1,0,"}, "--x0: value 3 of '1,0,' is empty"},
        {{"step", rb, "--x0", ",1,0"}, "--x0: value 1 of ',1,0' is empty"},
        {{"step", rb, "--x0", "1,,0"}, "--x0: value 2 of '1,,0' is empty"},
        {{"step", rb, "--x0", "1,0,1e999"}, "--x0:"},
    };
    for (const auto& [args_, message] : cases) {
        const auto& args = args_;  // (a name, not a binding: CAPTURE is a lambda)
        CAPTURE(args[2]);
        CAPTURE(args.size() > 3 ? args[3] : "");
        Run r = pgi_run(args);
        CHECK(r.exit_code == 2);
        CHECK(r.out.empty());
        CHECK_MESSAGE(r.err.find(message) != std::string::npos, r.err);
    }
    CHECK_FALSE(fs::exists("/tmp/pgi_never.csv"));
}

// issue 11.6
TEST_CASE("a Casimir through 0 has its error measured against the size of its terms, not against |C(x0)|") {
    // C = x1^2 + x2^2 + x3^2 - 1 at a point of the unit sphere: C(x0) = -1.1e-16 in double, the size of its
    // terms 2; 57dddde divided the round-off drift by |C(x0)| and reported about 2
    TempScene scene("casimir_zero",
                    "name = \"rigid body, C through 0\"\ncoordinates = [\"x1\", \"x2\", \"x3\"]\n[brackets]\n"
                    "\"x1,x2\" = \"-x3\"\n\"x2,x3\" = \"-x1\"\n\"x3,x1\" = \"-x2\"\n[hamiltonian]\n"
                    "H = \"1/4*x1^2 + 1/2*x2^2 + 3/4*x3^2\"\ncasimirs = [\"x1^2 + x2^2 + x3^2 - 1\"]\n"
                    "[run]\nx0 = [0.3, 0.4, 0.8660254037844386]\nt_end = 100\n");
    Run r = pgi_run({"integrate", scene.path.string(), "--json"});
    REQUIRE(r.exit_code == 0);
    // 1000 steps of a method that keeps C to round-off: a few eps of the terms' size, far below 1e-14
    CHECK(nlohmann::json::parse(r.out)["casimir_error_max"][0].get<double>() < 1e-14);
    // the shared rule itself (pgi and pgi_peers): |value - initial| / sum of |terms| at x0
    Scene s = load_scene(scene.path);
    const auto scale = invariant_scales(s, *s.x0);
    REQUIRE(scale.size() == 2);
    CHECK(scale[0] == doctest::Approx(0.25 * 0.09 + 0.5 * 0.16 + 0.75 * 0.75).epsilon(1e-15));
    CHECK(scale[1] == doctest::Approx(0.09 + 0.16 + 0.75 + 1).epsilon(1e-15));
    CHECK(relative_error(-1.1e-16 + 2.2e-16, -1.1e-16, scale[1]) == doctest::Approx(1.1e-16).epsilon(1e-6));
    CHECK(relative_error(3.0, 1.0, 0.0) == 2.0);  // all terms 0 at x0: the absolute change
}

// issue 11.7
TEST_CASE("output paths are checked before the run; temporaries are exclusive and removed on SIGTERM") {
    const std::string rb = test::scene_path("rigid_body");
    TempDir dir("files");
    const fs::path fifo = dir.path / "fifo.csv";
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    // (a device node is tested through check_output_path alone: a broken pgi run as root would replace /dev/null)
    CHECK_THROWS_WITH_AS(check_output_path("/dev/null"),
                         doctest::Contains("not a regular file (a device or special file)"), std::invalid_argument);
    for (const std::string& target : std::vector<std::string>{fifo.string(), dir.path.string()}) {
        CAPTURE(target);
        Run r = pgi_run({"integrate", rb, "--csv", target});
        CHECK(r.exit_code == 2);
        CHECK(r.out.empty());
        CHECK_MESSAGE(r.err.find("cannot write: it exists and is not a regular file") != std::string::npos, r.err);
    }
    CHECK(fs::is_fifo(fifo));
    // the scene itself, through another name, is never overwritten
    const fs::path copy = dir.path / "scene.toml", link = dir.path / "alias.toml";
    fs::copy_file(rb, copy);
    fs::create_symlink(copy, link);
    const std::string before = slurp(copy);
    Run self = pgi_run({"integrate", copy.string(), "--csv", link.string()});
    CHECK(self.exit_code == 2);
    CHECK_MESSAGE(self.err.find("cannot write: it is the input file") != std::string::npos, self.err);
    Run report_self = pgi_run({"report", copy.string(), "--out", copy.string()});
    CHECK(report_self.exit_code == 2);
    CHECK(slurp(copy) == before);
    // a scene that is a FIFO or a directory is refused without blocking
    Run fifo_scene = pgi_run({"check", fifo.string()});
    CHECK(fifo_scene.exit_code == 2);
    CHECK(fifo_scene.err.find("is not a regular file") != std::string::npos);
    Run dir_scene = pgi_run({"check", dir.path.string()});
    CHECK(dir_scene.exit_code == 2);
    CHECK(dir_scene.err.find("is a directory") != std::string::npos);
    // SIGTERM during a long run: exit 143 and no temporary file left (57dddde left "out.csv.tmp<pid>")
    fs::remove(fifo);
    const fs::path out = dir.path / "out.csv";
    const int rc = shell("timeout --preserve-status -s TERM 1 '" + std::string(PGI_BINARY) + "' integrate '" + rb +
                         "' --t-end 1e6 --dt 1/100 --every 1000000 --csv '" + out.string() + "' >/dev/null 2>&1");
    CHECK(rc == 143);
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(dir.path)) left.push_back(e.path().filename().string());
    std::sort(left.begin(), left.end());
    CHECK(left == std::vector<std::string>{"alias.toml", "scene.toml"});
    // a failed write to stdout: exit 6 with a message
    CHECK(shell("'" + std::string(PGI_BINARY) + "' terms '" + rb + "' > /dev/full 2>/dev/null") == 6);
    // a successful file keeps the permissions of an ordinary new file, not mkstemp's 0600
    Run ok = pgi_run({"integrate", rb, "--t-end", "1", "--csv", out.string()});
    REQUIRE(ok.exit_code == 0);
    struct stat st {};
    REQUIRE(::stat(out.c_str(), &st) == 0);
    const mode_t mask = ::umask(0);
    ::umask(mask);
    CHECK((st.st_mode & 0777) == (0666 & ~mask));
}

// issue 11.8
TEST_CASE("names with control characters are refused; what can be checked is checked before anything is printed") {
    TempScene name("ctl_name",
                   "name = \"a\\u001b[2Jb\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = "
                   "\"1\"\n[hamiltonian]\nH = \"q^2\"\n");
    Run r = pgi_run({"check", name.path.string()});
    CHECK(r.exit_code == 2);
    CHECK(r.out.empty());
    CHECK_MESSAGE(r.err.find(": name: contains a control character: 'a\\x1b[2Jb'") != std::string::npos, r.err);
    CHECK(r.err.find('\x1b') == std::string::npos);  // never echoed raw to the terminal
    TempScene coord(
        "ctl_coord",
        "name = \"n\"\ncoordinates = [\"q\\u0007\", \"p\"]\n[brackets]\n\"p,p\" = \"0\"\n[hamiltonian]\nH = \"p^2\"\n");
    Run c = pgi_run({"check", coord.path.string()});
    CHECK(c.exit_code == 2);
    CHECK_MESSAGE(
        c.err.find("coordinates[0]: the coordinate name 'q\\x07' contains a control character") != std::string::npos,
        c.err);
    // 57dddde printed eleven lines of check and terms before finding the directory missing
    Run nodir = pgi_run({"run", test::scene_path("rigid_body"), "--csv", "nodir/x.csv"});
    CHECK(nodir.exit_code == 2);
    CHECK(nodir.out.empty());
    CHECK(nodir.err.find("nodir/x.csv: cannot write: directory 'nodir' does not exist") != std::string::npos);
    // LaTeX: names that are not plain identifiers are set upright, never a double subscript (57dddde wrote
    // x_^{2} and x_{1}_{a}, which pdflatex refuses)
    TempDir dir("latex_names");
    TempScene odd("latex_names",
                  "name = \"a_b & c%\"\ncoordinates = [\"x_\", \"_y\", \"a_b_c\", \"x1_a\", \"x__2\"]\n"
                  "[brackets]\n\"x_,_y\" = \"a_b_c\"\n[hamiltonian]\nH = \"x_^2 + _y^2 + a_b_c + x1_a*x__2\"\n");
    Run tex = pgi_run({"report", odd.path.string(), "--format", "latex", "--out", (dir.path / "r.tex").string()});
    REQUIRE(tex.exit_code == 0);
    const std::string text = slurp(dir.path / "r.tex");
    CHECK(text.find("\\mathrm{x\\_}^{2}") != std::string::npos);
    CHECK(text.find("\\mathrm{x1\\_a}") != std::string::npos);
    const int rc =
        shell("cd '" + dir.path.string() + "' && pdflatex -interaction=nonstopmode -halt-on-error r.tex > r.log 2>&1");
    CHECK_MESSAGE(rc == 0, slurp(dir.path / "r.log"));
}

// issue 13
TEST_CASE("--trust-jacobi skips the Jacobi check and says so; without it a non-Jacobi structure is refused") {
    const std::string bad = (fs::path(PGI_SCENES_DIR) / "../../tests/bad_scenes/jacobi_failure.toml").string();
    const std::string note = "the Jacobi identity is not checked (--trust-jacobi";
    // refused without the option, before any work
    Run refused = pgi_run({"terms", bad, "--json"});
    CHECK(refused.exit_code == 2);
    CHECK(refused.out.empty());
    CHECK(refused.err.find("the Jacobi identity fails at (x1, x2, x3)") != std::string::npos);
    // with it the structure is taken on trust: the command runs, stderr and the JSON document say so
    Run trusted = pgi_run({"terms", bad, "--json", "--trust-jacobi"});
    CHECK(trusted.exit_code == 0);
    CHECK(trusted.err.find(note) != std::string::npos);
    CHECK(nlohmann::json::parse(trusted.out)["jacobi_checked"] == false);
    // check reports the verdict as skipped, not as holding, and the other checks still run
    Run check = pgi_run({"check", test::scene_path("rigid_body"), "--json", "--trust-jacobi"});
    CHECK(check.exit_code == 0);
    CHECK(check.err.find(note) != std::string::npos);
    const auto j = nlohmann::json::parse(check.out);
    CHECK(j["jacobi"]["holds"].is_null());
    CHECK(j["jacobi"]["skipped"] == "--trust-jacobi");
    CHECK(j["casimirs"][0]["holds"] == true);
    CHECK(j["realisation"]["holds"] == true);
    Run text = pgi_run({"check", test::scene_path("rigid_body"), "--trust-jacobi"});
    CHECK(text.out.find("Jacobi identity: not checked (--trust-jacobi)") != std::string::npos);
    // a checked run says nothing of the kind
    Run checked = pgi_run({"terms", test::scene_path("rigid_body"), "--json"});
    CHECK(checked.err.find(note) == std::string::npos);
    CHECK_FALSE(nlohmann::json::parse(checked.out).contains("jacobi_checked"));
    // report does not take it (its document states the verdict): an unknown option, exit 2
    CHECK(pgi_run({"report", test::scene_path("rigid_body"), "--trust-jacobi"}).exit_code == 2);
}

TEST_CASE("--plot-coords: the trajectory figure projects onto the coordinates named; bad ones are refused first") {
    const std::string chain = test::scene_path("volterra_chain");
    TempDir dir("plot_coords");
    const auto svg = [&](const std::string& name) { return slurp(dir.path / (name + "-trajectory.svg")); };
    if (shell("command -v gnuplot >/dev/null 2>&1") == 0) {
        Run picked =
            pgi_run({"integrate", chain, "--t-end", "1", "--plot", dir.path.string(), "--plot-coords", "x2,5"});
        REQUIRE(picked.exit_code == 0);
        CHECK(svg("volterra_chain").find("projection onto (x2, x5)") != std::string::npos);
        Run again = pgi_run({"run", chain, "--t-end", "1", "--plot", dir.path.string()});  // n = 6: the first three
        REQUIRE(again.exit_code == 0);
        CHECK_MESSAGE(again.err.find(dir.path.string() + "/volterra_chain-2-trajectory.svg") != std::string::npos,
                      again.err);
        CHECK(svg("volterra_chain-2").find("projection onto (x1, x2, x3)") != std::string::npos);
        CHECK(svg("volterra_chain").find("projection onto (x2, x5)") != std::string::npos);  // the first kept
    }
    std::size_t before = 0;
    for (const auto& e : fs::directory_iterator(dir.path)) before += e.is_regular_file();
    Run bad = pgi_run({"integrate", chain, "--plot", dir.path.string(), "--plot-coords", "x2,q"});
    CHECK(bad.exit_code == 2);
    CHECK(bad.out.empty());
    CHECK(bad.err == "pgi: " + chain +
                         ": --plot-coords: 'q' is not a coordinate (the coordinates are x1, x2, x3, x4, x5, x6, or "
                         "1..6)\n");
    Run alone = pgi_run({"integrate", chain, "--plot-coords", "x1,x2"});
    CHECK(alone.exit_code == 2);
    CHECK_MESSAGE(alone.err.find("--plot") != std::string::npos, alone.err);
    std::size_t after = 0;
    for (const auto& e : fs::directory_iterator(dir.path)) after += e.is_regular_file();
    CHECK(after == before);
}

TEST_CASE("--plot: gnuplot failing after the run is an output failure (exit 6), nothing left behind") {
    // (the figures themselves are tested in tools_report.cpp)
    const std::string rb = test::scene_path("rigid_body");
    const fs::path dir = fs::temp_directory_path() / ("pgi_test_plot_" + std::to_string(::getpid()));
    fs::create_directories(dir / "bin");
    // a gnuplot that fails: the run has finished, its figures cannot be written
    const fs::path fake = dir / "bin" / "gnuplot";
    std::ofstream(fake) << "#!/bin/sh\necho 'simulated failure' >&2\nexit 1\n";
    fs::permissions(fake, fs::perms::owner_all);
    Run failed = pgi_run({"integrate", rb, "--t-end", "1", "--plot", dir.string()},
                         "PATH='" + (dir / "bin").string() + "':\"$PATH\"");
    CHECK(failed.exit_code == 6);
    CHECK_MESSAGE(failed.err.find("--plot: gnuplot failed") != std::string::npos, failed.err);
    for (const auto& e : fs::directory_iterator(dir)) CHECK_MESSAGE(e.path().filename() == "bin", e.path());
    fs::remove_all(dir);
}

TEST_CASE(
    "cli: integrate --jit (or integrator.jit) ends where the interpreted run ends, bit for bit; by default a kept "
    "library is used, --no-jit never; a missing compiler is exit 7 with --jit, and nothing without it") {
    TempDir cache("jit_cache");
    const std::string env = "PGI_JIT_CACHE='" + cache.path.string() + "'";
    const std::string lv = test::scene_path("lotka_volterra");
    const std::vector<std::string> args = {"integrate", lv, "--order", "6", "--t-end", "5", "--json"};
    Run plain = pgi_run(args, env);
    std::vector<std::string> with_jit = args;
    with_jit.push_back("--jit");
    Run jit = pgi_run(with_jit, env);
    REQUIRE(plain.exit_code == 0);
    REQUIRE(jit.exit_code == 0);
    const auto a = nlohmann::json::parse(plain.out), b = nlohmann::json::parse(jit.out);
    CHECK(a["native_maps"].get<int>() == 0);
    CHECK(b["native_maps"].get<int>() > 0);
    CHECK(a["x"] == b["x"]);  // printed in the shortest form that reads back: equal text, equal doubles
    CHECK(a["steps"] == b["steps"]);
    // without an option the library --jit kept is used at once; --no-jit keeps the interpreter; not both
    Run kept = pgi_run(args, env);
    REQUIRE(kept.exit_code == 0);
    CHECK(nlohmann::json::parse(kept.out)["native_maps"] == b["native_maps"]);
    CHECK(nlohmann::json::parse(kept.out)["x"] == a["x"]);
    std::vector<std::string> no_jit = args;
    no_jit.push_back("--no-jit");
    Run never = pgi_run(no_jit, env);
    REQUIRE(never.exit_code == 0);
    CHECK(nlohmann::json::parse(never.out)["native_maps"].get<int>() == 0);
    CHECK(nlohmann::json::parse(never.out)["x"] == a["x"]);
    no_jit.push_back("--jit");
    CHECK(pgi_run(no_jit, env).exit_code == 2);
    // the scene's own switch, and a wrong type for it
    std::string text = slurp(lv);
    const auto at = text.find("[integrator]");
    REQUIRE(at != std::string::npos);
    TempScene yes("jit_yes", std::string(text).insert(at + 13, "jit = true\n"));
    Run from_scene = pgi_run({"integrate", yes.path.string(), "--order", "6", "--t-end", "5", "--json"}, env);
    REQUIRE(from_scene.exit_code == 0);
    CHECK(nlohmann::json::parse(from_scene.out)["x"] == a["x"]);
    TempScene bad("jit_bad", std::string(text).insert(at + 13, "jit = \"yes\"\n"));
    Run refused = pgi_run({"integrate", bad.path.string(), "--json"}, env);
    CHECK(refused.exit_code == 2);
    CHECK(refused.err.find("integrator.jit") != std::string::npos);
    Run no_compiler = pgi_run(with_jit, env + " PGI_CXX=/nonexistent/pgi-cc");
    CHECK(no_compiler.exit_code == 7);
    CHECK(no_compiler.out.empty());
    CHECK(no_compiler.err.find("/nonexistent/pgi-cc") != std::string::npos);
    TempDir empty("jit_cache_empty");  // by default a short run never needs the compiler
    Run automatic = pgi_run(args, "PGI_JIT_CACHE='" + empty.path.string() + "' PGI_CXX=/nonexistent/pgi-cc");
    CHECK(automatic.exit_code == 0);
    CHECK(nlohmann::json::parse(automatic.out)["x"] == a["x"]);
}
