// pgi: the command-line program. Exit codes: 0 success, 2 bad input (nothing on stdout), 3 a step failed
// (Newton did not converge or the state overflowed), 1 internal error.
#include "tools/atomic_file.hpp"
#include "scheme/version.hpp"
#include "tools/commands.hpp"
#include "tools/ensemble.hpp"
#include "tools/plot.hpp"
#include "tools/section.hpp"

#include <CLI/CLI.hpp>

#include <flint/flint.h>

#include <cstdlib>
#include <functional>
#include <iostream>

namespace {

struct Options {
    std::string scene;
    bool json = false;
    pgi::SceneOverrides overrides;
    std::size_t degree = 0;
    std::size_t upto = 4;
    std::string format = "markdown", out;
    pgi::IntegrateOptions integrate;
    std::string csv;
    std::string splitting;  // pgi modified --splitting
    std::string plot;       // pgi run/integrate --plot DIR
    pgi::SectionOptions section;
    pgi::EnsembleCommandOptions ensemble;
};

// The options a subcommand reads, and only those: each flag of Use says which of the scene's values it uses.
namespace use {
enum : unsigned { json = 1, order = 2, dt = 4, realisation = 8, x0 = 16, t_end = 32 };
}

void scene_options(CLI::App* cmd, Options& o, unsigned uses) {
    cmd->add_option("scene", o.scene, "scene file (TOML)")->required();
    if (uses & use::json) cmd->add_flag("--json", o.json, "print JSON");
    if (uses & use::order) cmd->add_option("--order", o.overrides.order, "Hamilton-Jacobi order k (overrides integrator.order)");
    if (uses & use::dt) cmd->add_option("--dt", o.overrides.dt, "time step, a decimal or a rational like 1/100");
    if (uses & use::realisation) cmd->add_option("--realisation", o.overrides.realisation, "auto | closed-form | radial");
    if (uses & use::x0) cmd->add_option("--x0", o.overrides.x0, "initial state, comma-separated");
    if (uses & use::t_end) cmd->add_option("--t-end", o.overrides.t_end, "final time");
    cmd->add_option("--max-terms", o.overrides.max_terms, "bound on the terms of any product of the exact phase")
        ->check(CLI::PositiveNumber);
}

void emit(const Options& o, const nlohmann::json& report, const std::function<std::string(const nlohmann::json&)>& text) {
    if (o.json) std::cout << report.dump(2) << "\n";
    else std::cout << text(report);
}

int run_command(const std::string& name, const Options& o) {
    pgi::Scene scene = pgi::load_scene(o.scene, o.overrides);
    if (name == "ensemble") {
        auto eo = o.ensemble;
        eo.x0_given = o.overrides.x0.has_value();
        return pgi::ensemble_command(scene, eo, o.json);
    }
    if (name == "check") {
        auto report = pgi::check_report(scene);
        emit(o, report, pgi::check_text);
        if (!report["ok"]) {
            std::cerr << "pgi: " << o.scene << ": a check fails (see the report)\n";
            return 2;
        }
        return 0;
    }
    pgi::require_valid(scene);
    if (name == "terms") emit(o, pgi::terms_report(scene), pgi::terms_text);
    if (name == "realisation") emit(o, pgi::realisation_report(scene, o.degree), pgi::realisation_text);
    if (name == "magnus") emit(o, pgi::magnus_report(scene, o.upto), pgi::series_text);
    if (name == "modified" && !o.splitting.empty())
        emit(o, pgi::splitting_report(scene, pgi::parse_splitting_method(o.splitting), o.upto), pgi::splitting_text);
    else if (name == "modified") emit(o, pgi::modified_report(scene, o.upto), pgi::series_text);
    if (name == "report") {
        auto data = pgi::report_data(scene, o.upto);
        std::string text = o.format == "json" ? data.dump(2) + "\n" : o.format == "latex" ? pgi::report_latex(data) : pgi::report_markdown(data);
        if (o.out.empty()) {
            std::cout << text;
        } else {
            pgi::AtomicFile file(o.out);
            file.stream() << text;
            file.commit();
        }
    }
    if (name == "step") emit(o, pgi::step_report(scene), pgi::step_text);
    pgi::IntegrateOptions io = o.integrate;
    if (!o.csv.empty()) io.csv = o.csv;
    io.progress = !o.json;
    std::optional<pgi::RunPlot> plot;  // checked before the run
    if (!o.plot.empty() && (name == "integrate" || name == "run")) {
        plot.emplace(scene, o.plot);
        plot->attach(io);
    }
    if (name == "section") {
        pgi::SectionOptions so = o.section;
        if (!o.csv.empty()) so.csv = o.csv;
        emit(o, pgi::section_report(scene, so), pgi::section_text);
    }
    if (name == "integrate") emit(o, pgi::integrate_report(scene, io), pgi::integrate_text);
    if (name == "run") {
        std::cout << pgi::check_text(pgi::check_report(scene)) << "\n" << pgi::terms_text(pgi::terms_report(scene)) << "\n"
                  << std::flush;
        if (scene.x0 && scene.t_end) std::cout << pgi::integrate_text(pgi::integrate_report(scene, io));
    }
    if (plot)
        for (const auto& f : plot->write()) std::cerr << "pgi: wrote " << f.string() << "\n";
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    std::atexit(flint_cleanup_master);  // FLINT's own caches, so memcheck sees every block freed
    CLI::App app{"pgi: exact Poisson integrators from symplectic groupoids"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "pgi " + std::string(pgi::version()));
    Options o;
    auto* check = app.add_subcommand("check", "class, Jacobi, Casimirs and realisation identities of a scene");
    auto* terms = app.add_subcommand("terms", "the Hamilton-Jacobi terms S_1..S_k");
    auto* realisation = app.add_subcommand("realisation", "alpha and beta truncated at a p-degree");
    auto* step = app.add_subcommand("step", "one step from x0");
    auto* integrate = app.add_subcommand("integrate", "integrate from x0 to t_end");
    auto* run = app.add_subcommand("run", "the main job: checks, S_1..S_k, and the integration when the scene has [run]");
    auto* magnus = app.add_subcommand("magnus", "the Magnus series of the scene's [magnus] h");
    auto* modified = app.add_subcommand("modified", "the modified Hamiltonian of the order-k scheme");
    auto* report = app.add_subcommand("report", "one document: structure, checks, S_1..S_k, modified Hamiltonian, a run");
    auto* ensemble = app.add_subcommand("ensemble", "many initial states (a file or a sampler) integrated on every core");
    scene_options(check, o, use::json | use::order | use::realisation);
    scene_options(terms, o, use::json | use::order | use::realisation);
    scene_options(realisation, o, use::json | use::realisation);
    scene_options(step, o, use::json | use::order | use::dt | use::realisation | use::x0);
    scene_options(integrate, o, use::json | use::order | use::dt | use::realisation | use::x0 | use::t_end);
    scene_options(run, o, use::order | use::dt | use::realisation | use::x0 | use::t_end);  // text only: its parts have --json
    scene_options(magnus, o, use::json);
    scene_options(modified, o, use::json | use::order | use::realisation);
    scene_options(report, o, use::order | use::dt | use::realisation | use::x0 | use::t_end);  // --format json
    auto* section = app.add_subcommand("section", "the crossings of an event polynomial along the run (a Poincare section)");
    scene_options(section, o, use::json | use::order | use::dt | use::realisation | use::x0 | use::t_end);
    section->add_option("--event", o.section.event, "the polynomial g whose zeros are reported")->required();
    section->add_option("--direction", o.section.direction, "1: g rising through 0, -1: falling, 0: both (default)")
        ->check(CLI::IsMember({-1, 0, 1}));
    section->add_option("--max-crossings", o.section.max_crossings, "stop after this many crossings")->check(CLI::PositiveNumber);
    section->add_option("--samples", o.section.samples, "sign tests per step on the dense output (default 1: the ends)")
        ->check(CLI::PositiveNumber);
    section->add_option("--csv", o.csv, "write the crossings (t, coordinates) to this CSV file");
    scene_options(ensemble, o, use::json | use::order | use::dt | use::realisation | use::x0 | use::t_end);  // x0: --sample casimir
    pgi::add_ensemble_options(ensemble, o.ensemble);
    report->add_option("--format", o.format, "markdown | latex | json")->check(CLI::IsMember({"markdown", "latex", "json"}));
    report->add_option("--out", o.out, "write to this file (atomically) instead of stdout");
    report->add_option("--upto", o.upto, "last power of dt of the modified Hamiltonian (default 4)");
    magnus->add_option("--upto", o.upto, "last power of eps (default 4)");
    modified->add_option("--upto", o.upto, "last power of dt (default 4)");
    modified->add_option("--splitting", o.splitting, "lie-trotter | strang | yoshida: the splitting method's for [splitting] H = A + B")
        ->check(CLI::IsMember({"lie-trotter", "strang", "yoshida"}));
    for (auto* cmd : {integrate, run}) {
        cmd->add_option("--csv", o.csv, "write the trajectory (t, coordinates, H, Casimirs) to this CSV file");
        cmd->add_option("--every", o.integrate.every, "one CSV row every M steps")->check(CLI::PositiveNumber);
        cmd->add_option("--plot", o.plot, "draw the trajectory and the invariants' errors (SVG and PNG, by gnuplot) into this directory");
        cmd->add_option("--max-csv-mb", o.integrate.max_csv_mb, "refuse a CSV larger than this (default 1024)")
            ->check(CLI::PositiveNumber);
    }
    realisation->add_option("--degree", o.degree, "total degree D in the momenta")->required();
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    }
    try {
        return run_command(app.get_subcommands().front()->get_name(), o);
    } catch (const pgi::NumericalFailure& e) {
        std::cerr << "pgi: " << o.scene << ": " << e.what() << "\n";
        return 3;
    } catch (const pgi::SceneError& e) {
        std::cerr << "pgi: " << e.what() << "\n";
        return 2;
    } catch (const pgi::ResourceLimitError& e) {
        std::cerr << "pgi: " << o.scene << ": exact phase stopped: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << "pgi: " << o.scene << ": " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "pgi: internal error: " << e.what() << "\n";
        return 1;
    }
}
