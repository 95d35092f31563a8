// pgi: the command-line program. Exit codes: 0 success, 2 bad input (nothing on stdout), 3 a step failed
// (Newton did not converge or the state overflowed), 1 internal error.
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"

#include <CLI/CLI.hpp>

#include <flint/flint.h>
#include <gmp.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <new>
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
    bool quiet = false;
};

void scene_options(CLI::App* cmd, Options& o) {
    cmd->add_option("scene", o.scene, "scene file (TOML)")->required();
    cmd->add_flag("--json", o.json, "print JSON");
    cmd->add_option("--order", o.overrides.order, "Hamilton-Jacobi order k (overrides integrator.order)");
    cmd->add_option("--dt", o.overrides.dt, "time step, a decimal or a rational like 1/100");
    cmd->add_option("--realisation", o.overrides.realisation, "auto | closed-form | radial");
    cmd->add_option("--x0", o.overrides.x0, "initial state, comma-separated");
    cmd->add_option("--t-end", o.overrides.t_end, "final time");
    cmd->add_option("--max-terms", o.overrides.max_terms, "bound on the terms of any product of the exact phase")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--max-memory-mb", o.overrides.max_memory_mb,
                    "memory budget of the exact phase in MB (default: half the physical memory, at most 3/4 of ulimit -v)")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 40));
    cmd->add_option("--max-seconds", o.overrides.max_seconds, "time budget of the exact phase's algebra (default 60)")
        ->check(CLI::Range(1e-3, 1e9));
    cmd->add_flag("--quiet", o.quiet, "no progress lines on stderr");
}

// FLINT and GMP abort the process (SIGABRT, their message on stdout) when an allocation fails. Throwing
// std::bad_alloc from their allocator does unwind, but it leaves the FLINT object being built half-formed,
// and clearing it on the way out crashes; so an allocation failure inside them ends the process at once,
// with a message and exit code 5 (out of memory). Nothing is being written to a file during the exact phase.
[[noreturn]] void out_of_memory() {
    static const char message[] = "pgi: out of memory: an allocation in the exact algebra failed within the memory budget "
                                  "(lower --max-memory-mb or raise the memory limit, ulimit -v)\n";
    [[maybe_unused]] auto n = ::write(2, message, sizeof message - 1);
    std::_Exit(5);
}
void* checked_malloc(std::size_t n) {
    void* p = std::malloc(n);
    if (!p && n) out_of_memory();
    return p;
}
void* checked_calloc(std::size_t n, std::size_t size) {
    void* p = std::calloc(n, size);
    if (!p && n && size) out_of_memory();
    return p;
}
void* checked_realloc(void* old, std::size_t n) {
    void* p = std::realloc(old, n);
    if (!p && n) out_of_memory();
    return p;
}
void* gmp_realloc(void* old, std::size_t, std::size_t n) { return checked_realloc(old, n); }
void gmp_free(void* p, std::size_t) { std::free(p); }

void throw_on_allocation_failure() {
    __flint_set_memory_functions(checked_malloc, checked_calloc, checked_realloc, std::free);
    mp_set_memory_functions(checked_malloc, gmp_realloc, gmp_free);
}

void emit(const Options& o, const nlohmann::json& report, const std::function<std::string(const nlohmann::json&)>& text) {
    if (o.json) std::cout << report.dump(2) << "\n";
    else std::cout << text(report);
}

int run_command(const std::string& name, Options o) {
    if (!o.quiet && ::isatty(2)) o.overrides.progress = [](const std::string& line) { std::cerr << "pgi: " << line << std::endl; };
    pgi::Scene scene = pgi::load_scene(o.scene, o.overrides);
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
    if (name == "modified") emit(o, pgi::modified_report(scene, o.upto), pgi::series_text);
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
    if (name == "step") emit(o, pgi::step_report(scene), [](const nlohmann::json& r) { return r.dump(2) + "\n"; });
    pgi::IntegrateOptions io = o.integrate;
    if (!o.csv.empty()) io.csv = o.csv;
    io.progress = !o.json;
    if (name == "integrate") emit(o, pgi::integrate_report(scene, io), pgi::integrate_text);
    if (name == "run") {
        std::cout << pgi::check_text(pgi::check_report(scene)) << "\n" << pgi::terms_text(pgi::terms_report(scene)) << "\n"
                  << std::flush;
        if (scene.x0 && scene.t_end) std::cout << pgi::integrate_text(pgi::integrate_report(scene, io));
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    std::atexit(flint_cleanup_master);  // FLINT's own caches, so memcheck sees every block freed
    throw_on_allocation_failure();
    CLI::App app{"pgi: exact Poisson integrators from symplectic groupoids"};
    app.require_subcommand(1);
    Options o;
    o.overrides.max_seconds = 60;  // the program's time budget of the exact phase (the library sets none)
    auto* check = app.add_subcommand("check", "class, Jacobi, Casimirs and realisation identities of a scene");
    auto* terms = app.add_subcommand("terms", "the Hamilton-Jacobi terms S_1..S_k");
    auto* realisation = app.add_subcommand("realisation", "alpha and beta truncated at a p-degree");
    auto* step = app.add_subcommand("step", "one step from x0 (JSON)");
    auto* integrate = app.add_subcommand("integrate", "integrate from x0 to t_end");
    auto* run = app.add_subcommand("run", "the main job: checks, S_1..S_k, and the integration when the scene has [run]");
    auto* magnus = app.add_subcommand("magnus", "the Magnus series of the scene's [magnus] h");
    auto* modified = app.add_subcommand("modified", "the modified Hamiltonian of the order-k scheme");
    auto* report = app.add_subcommand("report", "one document: structure, checks, S_1..S_k, modified Hamiltonian, a run");
    for (auto* cmd : {check, terms, realisation, step, integrate, run, magnus, modified, report}) scene_options(cmd, o);
    report->add_option("--format", o.format, "markdown | latex | json")->check(CLI::IsMember({"markdown", "latex", "json"}));
    report->add_option("--out", o.out, "write to this file (atomically) instead of stdout");
    report->add_option("--upto", o.upto, "last power of dt of the modified Hamiltonian (default 4)");
    magnus->add_option("--upto", o.upto, "last power of eps (default 4)");
    modified->add_option("--upto", o.upto, "last power of dt (default 4)");
    for (auto* cmd : {integrate, run}) {
        cmd->add_option("--csv", o.csv, "write the trajectory (t, coordinates, H, Casimirs) to this CSV file");
        cmd->add_option("--every", o.integrate.every, "one CSV row every M steps")->check(CLI::PositiveNumber);
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
        return 4;
    } catch (const std::bad_alloc&) {
        std::cerr << "pgi: " << o.scene << ": out of memory (an allocation failed within the memory budget; lower "
                     "--max-memory-mb or raise ulimit -v)\n";
        return 5;
    } catch (const std::invalid_argument& e) {
        std::cerr << "pgi: " << o.scene << ": " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "pgi: internal error: " << e.what() << "\n";
        return 1;
    }
}
