// pgi: the command-line program. Exit codes (README "Limits and exit codes"): 0 success; 1 internal error;
// 2 bad input (scene, options, paths, names, failed checks; nothing on stdout); 3 numerical failure (a step
// failed, a non-finite state or invariant); 4 a budget exceeded (exact phase, steps, CSV size); 5 out of
// memory; 6 output failure (stdout or a file); 130 / 143 interrupted by SIGINT / SIGTERM.
#include "tools/atomic_file.hpp"
#include "scheme/version.hpp"
#include "tools/commands.hpp"
#include "tools/ensemble.hpp"
#include "tools/plot.hpp"
#include "tools/program_allocator.hpp"
#include "tools/section.hpp"
#include "tools/lyapunov.hpp"
#include "tools/exit_codes.hpp"
#include "tools/option_values.hpp"
#include "scheme/detail/input_file.hpp"

#include <CLI/CLI.hpp>

#include <flint/flint.h>
#include <gmp.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <cmath>
#include <functional>
#include <iostream>
#include <new>
#include <string_view>

namespace {

// Numeric options are read as text and converted by read_numbers(), strictly and with their ranges.
struct Options {
    std::string scene;
    bool json = false;
    pgi::SceneOverrides overrides;
    std::string degree, upto = "4", every = "1", max_csv_mb = "1024", max_terms, max_steps, max_output_mb;
    std::size_t degree_value = 0, upto_value = 4;
    std::string format = "markdown", out;
    pgi::IntegrateOptions integrate;
    std::string csv;
    std::string splitting;      // pgi modified --splitting
    std::string plot;           // pgi run/integrate --plot DIR
    std::string plot_coords;    // --plot-coords x1,x3: the coordinates the trajectory figure draws
    std::string t_eval;         // --t-eval: a list of times, or a file of them
    bool t_eval_given = false;  // (so that an empty --t-eval is refused, not ignored)
    pgi::SectionOptions section;
    pgi::EnsembleCommandOptions ensemble;
    std::string max_memory_mb, max_seconds;  // the exact phase's budget, read by read_numbers
    bool quiet = false;
};

// The ranges of the numeric options (README "Limits and exit codes").
constexpr std::size_t max_degree = 100, max_upto = 64, max_count = std::size_t(1) << 53;

// --t-eval's times: the file the text names when it exists (read as every input file is: bounded, no special files),
// else the text itself when it looks like numbers (a digit, sign or point first, or a comma in it), else the file it
// names (whose absence is the message). Times are separated by commas, spaces or line breaks.
std::vector<double> read_times(const std::string& text) {
    std::error_code ec;
    const bool exists = !text.empty() &&
                        std::filesystem::symlink_status(text, ec).type() != std::filesystem::file_type::not_found &&
                        !ec;
    const bool numeric = text.empty() || text.find(',') != std::string::npos ||
                         std::string_view("0123456789+-.").find(text[0]) != std::string_view::npos;
    if (!exists && numeric) return pgi::number_list("--t-eval", text);
    constexpr std::size_t max_bytes = std::size_t(64) << 20;
    return pgi::number_list("--t-eval " + text, pgi::read_input_file(text, max_bytes, "--t-eval"));
}

void read_numbers(Options& o) {
    o.degree_value = o.degree.empty() ? 0 : pgi::whole_number("--degree", o.degree, 0, max_degree);
    o.upto_value = pgi::whole_number("--upto", o.upto, 0, max_upto);
    o.integrate.every = pgi::whole_number("--every", o.every, 1, max_count);
    o.integrate.max_csv_mb = pgi::positive_number("--max-csv-mb", o.max_csv_mb, 1e9);
    if (!o.max_terms.empty()) o.overrides.max_terms = pgi::whole_number("--max-terms", o.max_terms, 1, max_count);
    if (!o.max_steps.empty()) o.integrate.max_steps = pgi::whole_number("--max-steps", o.max_steps, 1, max_count);
    o.ensemble.limits.max_steps = o.integrate.max_steps;
    if (!o.max_output_mb.empty())
        o.ensemble.limits.max_output_mb = pgi::positive_number("--max-output-mb", o.max_output_mb, 1e9);
    if (!o.max_memory_mb.empty())
        o.overrides.max_memory_mb = pgi::whole_number("--max-memory-mb", o.max_memory_mb, 1, std::size_t(1) << 40);
    if (!o.max_seconds.empty()) o.overrides.max_seconds = pgi::positive_number("--max-seconds", o.max_seconds, 1e9);
    if (o.t_eval_given) o.integrate.t_eval = read_times(o.t_eval);
}

// Standard output, flushed and checked: a closed pipe or a full disk is an OutputError (exit 6).
void print(const std::string& text) {
    std::cout << text << std::flush;
    if (!std::cout) throw pgi::OutputError(std::string("standard output: write failed (") + std::strerror(errno) + ")");
}

// The options a subcommand reads, and only those: each flag of Use says which of the scene's values it uses.
namespace use {
enum : unsigned { json = 1, order = 2, dt = 4, realisation = 8, x0 = 16, t_end = 32, trust = 64, jit = 128 };
}

void scene_options(CLI::App* cmd, Options& o, unsigned uses) {
    cmd->add_option("scene", o.scene, "scene file (TOML)")->required();
    if (uses & use::json) cmd->add_flag("--json", o.json, "print JSON");
    if (uses & use::order)
        cmd->add_option("--order", o.overrides.order, "Hamilton-Jacobi order k (overrides integrator.order)");
    if (uses & use::dt) cmd->add_option("--dt", o.overrides.dt, "time step, a decimal or a rational like 1/100");
    if (uses & use::realisation)
        cmd->add_option("--realisation", o.overrides.realisation, "auto | closed-form | radial");
    if (uses & use::x0) cmd->add_option("--x0", o.overrides.x0, "initial state, comma-separated");
    if (uses & use::x0)
        cmd->add_option("--param", o.overrides.parameters,
                        "a parameter's value for the run, NAME=VALUE (a decimal or a rational a/b; repeatable)");
    if (uses & use::t_end) cmd->add_option("--t-end", o.overrides.t_end, "final time");
    if (uses & use::trust)
        cmd->add_flag("--trust-jacobi", o.overrides.trust_jacobi,
                      "do not check the Jacobi identity: you vouch for the structure (reported on stderr and in JSON)");
    if (uses & use::jit) {
        const auto policy = [&o](pgi::NativePolicy p) { return [&o, p](std::int64_t) { o.overrides.jit = p; }; };
        CLI::Option* always = cmd->add_flag_function(
            "--jit", policy(pgi::NativePolicy::always),
            "build the step's maps as native code before the first step (system C++ compiler; the same numbers). By "
            "default pgi uses native code it has kept (~/.cache/pgi/jit) and builds it in the background during a "
            "long run; integrator.jit = true");
        cmd->add_flag_function("--no-jit", policy(pgi::NativePolicy::never),
                               "never native code: the interpreter only (integrator.jit = false)")
            ->excludes(always);
    }
    cmd->add_option("--max-terms", o.max_terms, "bound on the terms of any product of the exact phase (default 2e7)");
    cmd->add_option(
        "--max-memory-mb", o.max_memory_mb,
        "memory budget of the exact phase in MB (default: half the physical memory, at most 3/4 of ulimit -v)");
    cmd->add_option("--max-seconds", o.max_seconds, "time budget of the exact phase's algebra (default 60)");
    cmd->add_flag("--quiet", o.quiet, "no progress lines on stderr");
}

// FLINT and GMP abort the process (SIGABRT, their message on stdout) when an allocation fails. Throwing
// std::bad_alloc from their allocator does unwind, but it leaves the FLINT object being built half-formed,
// and clearing it on the way out crashes; so an allocation failure inside them ends the process at once,
// with a message and exit code 5 (out of memory). Nothing is being written to a file during the exact phase.
[[noreturn]] void out_of_memory() {
    static const char message[] =
        "pgi: out of memory: an allocation in the exact algebra failed within the memory budget "
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
void* gmp_realloc(void* old, std::size_t, std::size_t n) {
    return checked_realloc(old, n);
}
void gmp_free(void* p, std::size_t) {
    std::free(p);
}

void throw_on_allocation_failure() {
    __flint_set_memory_functions(checked_malloc, checked_calloc, checked_realloc, std::free);
    mp_set_memory_functions(checked_malloc, gmp_realloc, gmp_free);
}

void emit(const Options& o, const nlohmann::json& report,
          const std::function<std::string(const nlohmann::json&)>& text) {
    if (o.json && o.overrides.trust_jacobi && report.is_object()) {
        nlohmann::json marked = report;
        marked["jacobi_checked"] = false;  // --trust-jacobi: the document says the structure was taken on trust
        print(marked.dump(2) + "\n");
        return;
    }
    print(o.json ? report.dump(2) + "\n" : text(report));
}

// What can be refused before any work: output paths, a --csv without a run, the step count.
void check_before_work(const std::string& name, const Options& o, const pgi::Scene& scene) {
    const bool runs = name == "integrate" || name == "run" || name == "report" || name == "section";
    if (!o.csv.empty()) {
        if (name == "run" && !(scene.x0 && scene.t_end))
            throw pgi::SceneError(scene.file, "--csv",
                                  "the scene has no run to write (give [run] x0 and t_end, or --x0 and --t-end)");
        pgi::check_output_path(o.csv, {scene.file});
    }
    if (!o.out.empty()) pgi::check_output_path(o.out, {scene.file});
    if (runs && scene.t_end && (name == "integrate" || name == "section" || scene.x0))
        pgi::step_count(scene, o.integrate.max_steps);
}

int run_command(const std::string& name, Options o) {
    if (!o.quiet && ::isatty(2)) o.overrides.progress = [](const std::string& line) { pgi::say("pgi: " + line); };
    pgi::Scene scene = pgi::load_scene(o.scene, o.overrides);
    check_before_work(name, o, scene);
    if (o.overrides.trust_jacobi)
        pgi::say("pgi: " + o.scene +
                 ": the Jacobi identity is not checked (--trust-jacobi: the structure is taken on trust)");
    if (name == "ensemble") {
        auto eo = o.ensemble;
        eo.x0_given = o.overrides.x0.has_value();
        return pgi::ensemble_command(scene, eo, o.json);
    }
    if (name == "check") {
        auto report = pgi::check_report(scene);
        emit(o, report, pgi::check_text);
        if (!report["ok"]) {
            pgi::say("pgi: " + o.scene + ": a check fails (see the report)");
            return 2;
        }
        return 0;
    }
    pgi::require_valid(scene);
    if (name == "terms") emit(o, pgi::terms_report(scene), pgi::terms_text);
    if (name == "realisation") emit(o, pgi::realisation_report(scene, o.degree_value), pgi::realisation_text);
    if (name == "magnus") emit(o, pgi::magnus_report(scene, o.upto_value), pgi::series_text);
    if (name == "modified" && !o.splitting.empty())
        emit(o, pgi::splitting_report(scene, pgi::parse_splitting_method(o.splitting), o.upto_value),
             pgi::splitting_text);
    else if (name == "modified")
        emit(o, pgi::modified_report(scene, o.upto_value), pgi::series_text);
    if (name == "report") {
        auto data = pgi::report_data(scene, o.upto_value);
        std::string text = o.format == "json"    ? data.dump(2) + "\n"
                           : o.format == "latex" ? pgi::report_latex(data)
                                                 : pgi::report_markdown(data);
        if (o.out.empty()) {
            print(text);
        } else {
            pgi::AtomicFile file(o.out, {scene.file});
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
        plot.emplace(scene, o.plot, o.plot_coords);
        plot->attach(io);
    }
    if (name == "section") {
        pgi::SectionOptions so = o.section;
        if (!o.csv.empty()) so.csv = o.csv;
        so.max_steps = o.integrate.max_steps;
        emit(o, pgi::section_report(scene, so), pgi::section_text);
    }
    if (name == "integrate") emit(o, pgi::integrate_report(scene, io), pgi::integrate_text);
    if (name == "lyapunov")
        emit(o, pgi::lyapunov_report(scene, o.integrate.every, o.integrate.max_steps), pgi::lyapunov_text);
    if (name == "run") {
        print(pgi::check_text(pgi::check_report(scene)) + "\n" + pgi::terms_text(pgi::terms_report(scene)) + "\n");
        if (scene.x0 && scene.t_end) print(pgi::integrate_text(pgi::integrate_report(scene, io)));
    }
    if (plot)
        for (const auto& f : plot->write()) pgi::say("pgi: wrote " + f.string());
    return 0;
}

// Runs the command; exceptions become exit codes in tools/exit_codes.hpp. A failed run with --json
// still prints its partial document ("status": "step_failed", the last good state).
int run_and_map_exceptions(const std::string& name, Options& o) {
    try {
        read_numbers(o);
        return run_command(name, o);
    } catch (...) {
        const int code = pgi::exit_code_of_current_exception("pgi", o.scene);
        if (code == 3 && o.json) try {
                throw;
            } catch (const pgi::NumericalFailure& e) {
                if (!e.partial().is_null()) try {
                        print(e.partial().dump(2) + "\n");
                    } catch (const pgi::OutputError& out) {
                        pgi::say(std::string("pgi: ") + out.what());
                        return 6;
                    }
            } catch (...) {
            }
        return code;
    }
}

// A subcommand: its name, what it does, and its options. Only the invoked one's options are set up (all of them took
// 1.7 million instructions, about 0.2 ms of a 5 ms run: tools/bench/bench_startup.py); the help lists every
// subcommand by name.
struct Subcommand {
    const char* name;
    const char* what;
    std::function<void(CLI::App*)> options;
};

// The subcommand argv names: its first word that is not an option (pgi takes no option with a value before it).
std::string_view invoked(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return {};
}

}  // namespace

int main(int argc, char** argv) {
    std::atexit(flint_cleanup_master);  // FLINT's own caches, so memcheck sees every block freed
    std::signal(SIGPIPE, SIG_IGN);      // a closed pipe is a failed write (exit 6), not a silent death
    std::signal(SIGXFSZ, SIG_IGN);      // so is a file above the size limit (ulimit -f): EFBIG, not a core dump
    pgi::remove_temporaries_on_signals();
    throw_on_allocation_failure();
    CLI::App app{"pgi: exact Poisson integrators from symplectic groupoids"};
    app.require_subcommand(1);
    app.set_version_flag("--version",
                         "pgi " + std::string(pgi::version()) + " (allocator: " + pgi::program_allocator() + ")");
    Options o;
    o.overrides.max_seconds = 60;  // the program's time budget of the exact phase (the library sets none)
    const auto max_steps = [&o](CLI::App* cmd) {
        cmd->add_option("--max-steps", o.max_steps,
                        "refuse a run of more steps than this, before any work (default 1e8)");
    };
    const auto trajectory_outputs = [&o](CLI::App* cmd) {  // integrate's and run's
        auto* csv =
            cmd->add_option("--csv", o.csv, "write the trajectory (t, coordinates, H, Casimirs) to this CSV file");
        auto* every = cmd->add_option("--every", o.every, "one CSV row every M steps");
        cmd->add_option("--t-eval", o.t_eval,
                        "the CSV's rows at these times in [0, t_end], increasing, instead of every M steps: a list "
                        "(0.5,1,2.25) or a file of times; each is a true partial step of the method, on the leaf")
            ->each([&o](const std::string&) { o.t_eval_given = true; })
            ->needs(csv)
            ->excludes(every);
        auto* plot = cmd->add_option(
            "--plot", o.plot,
            "draw the trajectory and the invariants' errors (SVG and PNG, by gnuplot) into this directory");
        cmd->add_option("--plot-coords", o.plot_coords,
                        "the two or three coordinates the trajectory figure draws, names or 1-based indices "
                        "(default: the first three)")
            ->needs(plot);
        cmd->add_option("--max-csv-mb", o.max_csv_mb, "refuse a CSV larger than this (default 1024)");
    };
    constexpr unsigned run_uses =
        use::trust | use::order | use::dt | use::realisation | use::x0 | use::t_end | use::jit;
    const std::vector<Subcommand> subcommands{
        {"check", "class, Jacobi, Casimirs and realisation identities of a scene",
         [&](CLI::App* cmd) { scene_options(cmd, o, use::trust | use::json | use::order | use::realisation); }},
        {"terms", "the Hamilton-Jacobi terms S_1..S_k",
         [&](CLI::App* cmd) { scene_options(cmd, o, use::trust | use::json | use::order | use::realisation); }},
        {"realisation", "alpha and beta truncated at a p-degree",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, use::trust | use::json | use::realisation);
             cmd->add_option("--degree", o.degree, "total degree D in the momenta, 0..100")->required();
         }},
        {"step", "one step from x0",
         [&](CLI::App* cmd) {
             scene_options(cmd, o,
                           use::trust | use::json | use::order | use::dt | use::realisation | use::x0 | use::jit);
         }},
        {"integrate", "integrate from x0 to t_end",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, run_uses | use::json);
             max_steps(cmd);
             trajectory_outputs(cmd);
         }},
        {"run", "the main job: checks, S_1..S_k, and the integration when the scene has [run]",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, run_uses);  // text only: its parts have --json
             max_steps(cmd);
             trajectory_outputs(cmd);
         }},
        {"magnus", "the Magnus series of the scene's [magnus] h",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, use::trust | use::json);
             cmd->add_option("--upto", o.upto, "last power of eps, 0..64 (default 4)");
         }},
        {"modified", "the modified Hamiltonian of the order-k scheme",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, use::trust | use::json | use::order | use::realisation);
             cmd->add_option("--upto", o.upto, "last power of dt, 0..64 (default 4)");
             cmd->add_option("--splitting", o.splitting,
                             "lie-trotter | strang | yoshida: the splitting method's for [splitting] H = A + B")
                 ->check(CLI::IsMember({"lie-trotter", "strang", "yoshida"}));
         }},
        {"report", "one document: structure, checks, S_1..S_k, modified Hamiltonian, a run",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, use::order | use::dt | use::realisation | use::x0 | use::t_end);  // --format json
             cmd->add_option("--format", o.format, "markdown | latex | json")
                 ->check(CLI::IsMember({"markdown", "latex", "json"}));
             cmd->add_option("--out", o.out, "write to this file (atomically) instead of stdout");
             cmd->add_option("--upto", o.upto, "last power of dt of the modified Hamiltonian, 0..64 (default 4)");
             max_steps(cmd);
         }},
        {"ensemble", "many initial states (a file or a sampler) integrated on every core",
         [&](CLI::App* cmd) {
             scene_options(cmd, o,
                           use::json | use::order | use::dt | use::realisation | use::x0 | use::t_end);  // x0: --sample
             pgi::add_ensemble_options(cmd, o.ensemble);
             cmd->add_option("--max-output-mb", o.max_output_mb,
                             "refuse an ensemble whose results (or --states file) would take more than this, before "
                             "any work (default 1024)");
             max_steps(cmd);
         }},
        {"lyapunov", "the Lyapunov exponents along the run (Benettin's method)",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, run_uses | use::json);
             cmd->add_option("--every", o.every, "record the estimates every M steps (default 1)");
             max_steps(cmd);
         }},
        {"section", "the crossings of an event polynomial along the run (a Poincare section)",
         [&](CLI::App* cmd) {
             scene_options(cmd, o, run_uses | use::json);
             cmd->add_option("--event", o.section.event, "the polynomial g whose zeros are reported")->required();
             cmd->add_option("--direction", o.section.direction,
                             "1: g rising through 0, -1: falling, 0: both (default)")
                 ->check(CLI::IsMember({-1, 0, 1}));
             cmd->add_option("--max-crossings", o.section.max_crossings, "stop after this many crossings")
                 ->check(CLI::PositiveNumber);
             cmd->add_option("--samples", o.section.samples,
                             "sign tests per step on the dense output (default 1: the ends)")
                 ->check(CLI::PositiveNumber);
             cmd->add_option("--csv", o.csv, "write the crossings (t, coordinates) to this CSV file");
             max_steps(cmd);
         }},
    };
    const std::string_view chosen = invoked(argc, argv);
    for (const Subcommand& sub : subcommands) {
        CLI::App* cmd = app.add_subcommand(sub.name, sub.what);
        if (chosen == sub.name) sub.options(cmd);
    }
    try {
        app.parse(argc, argv);
        for (const char* name : {"--csv", "--out"})  // given but empty is not "not given"
            for (auto* cmd : app.get_subcommands())
                if (const auto* opt = cmd->get_option_no_throw(name);
                    opt && opt->count() > 0 &&
                    std::any_of(opt->results().begin(), opt->results().end(),
                                [](const std::string& r) { return r.empty(); })) {
                    pgi::say(std::string("pgi: ") + name + ": an empty path");
                    return 2;
                }
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    }
    return run_and_map_exceptions(app.get_subcommands().front()->get_name(), o);
}
