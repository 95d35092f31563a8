// The report side of pgi: splitting reports from scenes, LaTeX that fits the page (pdflatex when installed),
// plots of a run.
#include "series/latex.hpp"
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"
#include "tools/plot.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>

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

namespace {

namespace fs = std::filesystem;

// the widths (pt) of the overfull \hbox warnings in a pdflatex log
std::vector<double> overfull_widths(const std::string& log) {
    std::vector<double> widths;
    const std::string key = "Overfull \\hbox (";
    for (auto at = log.find(key); at != std::string::npos; at = log.find(key, at + 1))
        widths.push_back(std::stod(log.substr(at + key.size())));
    return widths;
}

// compiles the LaTeX text with pdflatex in a fresh directory; the log, or nothing when pdflatex is missing
std::optional<std::string> pdflatex_log(const std::string& tex, const std::string& name) {
    if (std::system("command -v pdflatex >/dev/null 2>&1") != 0) return std::nullopt;
    const fs::path dir = fs::temp_directory_path() / ("pgi_latex_" + std::to_string(::getpid()) + "_" + name);
    fs::create_directories(dir);
    std::ofstream(dir / "report.tex") << tex;
    const std::string cmd =
        "cd '" + dir.string() + "' && pdflatex -interaction=nonstopmode -halt-on-error report.tex >/dev/null 2>&1";
    const int status = std::system(cmd.c_str());
    std::ifstream in(dir / "report.log");
    std::stringstream log;
    log << in.rdbuf();
    const bool pdf = fs::exists(dir / "report.pdf");
    fs::remove_all(dir);
    CHECK_MESSAGE(status == 0, "pdflatex failed on the ", name, " report");
    CHECK(pdf);
    return log.str();
}

}  // namespace

TEST_CASE("latex_number: numbers typeset as numbers, not as math italic words") {
    CHECK(latex_number(6.266e-12) == "6.266\\times 10^{-12}");
    CHECK(latex_number(-2.5e7) == "-2.5\\times 10^{7}");
    CHECK(latex_number(1e-20) == "10^{-20}");
    CHECK(latex_number(9.99999e-5) == "10^{-4}");  // rounded before the exponent is read
    CHECK(latex_number(0.1) == "0.1");
    CHECK(latex_number(100) == "100");
    CHECK(latex_number(0) == "0");
}

TEST_CASE("latex_lines: breaks at + and - signs within the width, keeps every term once") {
    PhaseSpace M({"x1", "x2", "x3"});
    const Poly f = pow(M.parse("x1 + x2/3 - 5*x3/7 + 1"), 4);
    const auto lines = latex_lines(f, 20, 18);
    REQUIRE(lines.size() > 2);
    std::string joined;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        if (i > 0) CHECK((lines[i].rfind("+ ", 0) == 0 || lines[i].rfind("- ", 0) == 0));  // a line starts at a sign
        joined += (i ? " " : "") + lines[i];
    }
    CHECK(joined == to_latex(f));
    // each line within its budget by the same estimate
    double total = 0;
    for (const auto& t : latex_terms(f)) total += t.width;
    CHECK(total > 20 * double(lines.size() - 1) / 2);  // not broken needlessly: lines are at least half full on average
    CHECK(to_latex(M.parse("-x1^2/3 + 2")) == "-\\tfrac{1}{3} x_{1}^{2} + 2");
}

TEST_CASE("LaTeX reports of the Volterra lattice (k = 6) and Henon-Heiles (through dt^6) fit the page under pdflatex") {
    // any overfull \hbox wider than 1pt is a line running into the margin
    for (auto [scene, order, upto] :
         {std::tuple{"volterra_chain", "6", std::size_t(6)}, std::tuple{"henon_heiles", "4", std::size_t(6)}}) {
        const char* name = scene;  // (a name, not a binding: CHECK_MESSAGE is a lambda)
        SceneOverrides o;
        o.order = order;
        Scene s = load_scene(test::scene_path(name), o);
        const std::string tex = report_latex(report_data(s, upto));
        CHECK_FALSE(std::regex_search(tex, std::regex(R"([0-9]e[-+]?[0-9])")));  // no "6.266e-12" in math italic
        const auto log = pdflatex_log(tex, name);
        if (!log) {
            MESSAGE("pdflatex is not installed: the LaTeX reports were not compiled");
            return;
        }
        for (double w : overfull_widths(*log)) CHECK_MESSAGE(w <= 1.0, name, ": overfull \\hbox of ", w, "pt");
    }
}

TEST_CASE("LaTeX reports: a scene name in any script compiles; what pdflatex cannot set is shown as its code point") {
    Scene s = load_scene(test::scene_path("rigid_body"));
    s.name =
        "\xe5\x89\x9b\xe4\xbd\x93 \xe2\x80\x93 Euler\xe2\x80\x99s top \xc3\xa9 \xf0\x9f\x8c\x80 100% & x_1 ~\x01 \xff";
    const std::string tex = report_latex(report_data(s, 2));
    for (const std::string shown : {"\\texttt{U+525B}\\texttt{U+4F53}", "\xe2\x80\x93 Euler\xe2\x80\x99s top \xc3\xa9",
                                    "\\texttt{U+1F300} 100\\% \\& x\\_1 \\~{}\\texttt{U+0001} \\texttt{U+FFFD}"})
        CHECK_MESSAGE(tex.find(shown) != std::string::npos, shown);
    if (!pdflatex_log(tex, "names")) MESSAGE("pdflatex is not installed: the report was not compiled");
}

TEST_CASE("RunSeries: at most the requested number of bins, and every bin keeps its largest error") {
    RunSeries s(10000, 1, {"H"}, {1.0}, 100);  // H(x0) = 1 made of terms of size 1
    double x = 0;
    for (std::size_t n = 0; n <= 10000; ++n) {
        // the error peaks once, at step 4321, between two bins' first steps
        const double value = 1.0 + (n == 4321 ? 1e-3 : 1e-9 * double(n % 7));
        x = double(n);
        s.record(n, 0.01 * double(n), &x, {value});
    }
    CHECK(s.bins().size() <= 101);
    CHECK(s.bins().size() >= 90);
    double peak = 0, peak_t = 0;
    for (const auto& b : s.bins())
        if (b.error[0] > peak) peak = b.error[0], peak_t = b.error_t[0];
    CHECK(peak == doctest::Approx(1e-3).epsilon(1e-9));
    CHECK(peak_t == doctest::Approx(43.21));
    CHECK(s.bins().front().x[0] == 0);  // the trajectory keeps each bin's first state
}

TEST_CASE("RunPlot: a bad directory is refused before the run; a run draws four non-empty figures") {
    Scene scene = test::bundled("harmonic_oscillator");
    CHECK_THROWS_AS(RunPlot(scene, "/nonexistent/pgi"), SceneError);
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        MESSAGE("gnuplot is not installed: no figures drawn");
        return;
    }
    const fs::path dir = fs::temp_directory_path() / ("pgi_plot_test_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    scene.t_end = 5;
    RunPlot plot(scene, dir);
    IntegrateOptions options;
    plot.attach(options);
    REQUIRE(options.modified);  // the modified Hamiltonian is watched too
    integrate_report(scene, options);
    const auto files = plot.write();
    CHECK(files.size() == 4);
    for (const auto& f : files) {
        CHECK(fs::file_size(f) > 1000);
        std::ifstream in(f, std::ios::binary);
        std::string head(8, '\0');
        in.read(head.data(), 8);
        if (f.extension() == ".png")
            CHECK(head.substr(1, 3) == "PNG");
        else
            CHECK(head.find('<') != std::string::npos);
    }
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(dir)) entries += e.is_regular_file();
    CHECK(entries == 4);  // no temporary left behind
    fs::remove_all(dir);
}

TEST_CASE("plot coordinates: two or three names or 1-based indices; the first three by default") {
    const std::vector<std::string> c{"x1", "x2", "x3", "x4", "x5", "x6", "x7"};
    using Shown = std::vector<std::size_t>;
    CHECK(plot_coordinates(c, "") == Shown{0, 1, 2});
    CHECK(plot_coordinates({"q", "p"}, "") == Shown{0, 1});
    CHECK(plot_coordinates(c, "x2,x5") == Shown{1, 4});
    CHECK(plot_coordinates(c, "7, 1,x3") == Shown{6, 0, 2});
    const std::string there = " (the coordinates are x1, x2, x3, x4, x5, x6, ..., or 1..7)";
    const auto refused = [&](const std::string& spec) {
        try {
            plot_coordinates(c, spec);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    CHECK(refused("x1") ==
          "give two or three coordinates, comma-separated names or 1-based indices like x1,x2 (got 1 in 'x1')");
    CHECK(refused("1,2,3,4") ==
          "give two or three coordinates, comma-separated names or 1-based indices like x1,x2 (got 4 in '1,2,3,4')");
    CHECK(refused("x1,q") == "'q' is not a coordinate" + there);
    CHECK(refused("x1,8") == "index 8 is out of range" + there);
    CHECK(refused("0,x1") == "index 0 is out of range" + there);
    CHECK(refused("x1,1") == "'1' names coordinate x1 twice");
    CHECK(refused("x1,") == "an empty entry" + there);
    CHECK(refused("x1," + std::string(100000, '9')) == "index " + std::string(37, '9') + "... is out of range" + there);
}

TEST_CASE("RunPlot: a second run's figures get the next free name; no figure is ever replaced") {
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        MESSAGE("gnuplot is not installed: no figures drawn");
        return;
    }
    const fs::path dir = fs::temp_directory_path() / ("pgi_plot_names_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    Scene scene = test::bundled("harmonic_oscillator");
    scene.t_end = 2;
    const auto draw = [&](RunPlot& plot) {
        IntegrateOptions options;
        plot.attach(options);
        integrate_report(scene, options);
        return plot.write();
    };
    RunPlot first_plot(scene, dir);
    const auto first = draw(first_plot);
    REQUIRE(first == figure_paths(dir, "harmonic_oscillator"));
    std::vector<std::string> before;
    for (const auto& f : first) before.push_back(test::slurp(f));
    scene.t_end = 3;  // another run, other figures
    RunPlot second_plot(scene, dir);
    CHECK(second_plot.name() == "harmonic_oscillator-2");
    CHECK(draw(second_plot) == figure_paths(dir, "harmonic_oscillator-2"));
    for (std::size_t i = 0; i < first.size(); ++i) CHECK(test::slurp(first[i]) == before[i]);
    // a name taken between the check before the run and the drawing: refused, that file kept, none of the run's left
    RunPlot third_plot(scene, dir);
    REQUIRE(third_plot.name() == "harmonic_oscillator-3");
    const fs::path taken = dir / "harmonic_oscillator-3-errors.png";
    IntegrateOptions options;
    third_plot.attach(options);
    integrate_report(scene, options);
    std::ofstream(taken) << "someone else's";
    CHECK_THROWS_AS(third_plot.write(), OutputError);
    CHECK(test::slurp(taken) == "someone else's");
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(dir)) entries += e.is_regular_file();
    CHECK(entries == 4 + 4 + 1);  // the first two runs' figures and the intruder: nothing else, no temporary
    fs::remove_all(dir);
}

TEST_CASE("[splitting] A: refused when it is 0, H itself, or not a polynomial in the coordinates") {
    const std::string head =
        "name = \"s\"\ncoordinates = [\"q\", \"p\"]\n[brackets]\n\"q,p\" = \"1\"\n[hamiltonian]\nH = \"(q^2 + "
        "p^2)/2\"\n";
    for (const auto& [a, message] : {std::pair{"0", "splitting.A"}, std::pair{"p^2/2 + q^2/2", "splitting.A"},
                                     std::pair{"q^2 + r", "splitting.A"}}) {
        try {
            parse_scene(head + "[splitting]\nA = \"" + a + "\"\n", "s.toml");
            FAIL("accepted A = ", a);
        } catch (const SceneError& e) {
            CHECK(std::string(e.what()).find(message) != std::string::npos);
        }
    }
    CHECK_THROWS_AS(parse_scene(head + "[splitting]\nB = \"q\"\n", "s.toml"), SceneError);  // unknown key
    Scene s = parse_scene(head + "[splitting]\nA = \"q^2/2\"\n", "s.toml");
    REQUIRE(s.splitting_A);
    CHECK(s.H - *s.splitting_A == s.phase_space().parse("p^2/2"));
}
