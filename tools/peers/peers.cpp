// pgi_peers: pgi against GSL's and Boost.Odeint's integrators on one scene, in one run (issue 5). Not
// part of the core library: only this program links the peers. Each runs as its users run it (issue 33): the peers
// on a right-hand side of their own, pi grad H (and its Jacobian for the implicit peers) written in C from the
// scene's exact polynomials and compiled by the system C compiler ($CC, else cc; -O3 -march=native), loaded before
// any run; pgi through its C++ API in its default configuration (--jit adds it with native code from the start).
// --pgi-field PEERS adds these peers fed pgi's compiled field through pgi's interpreter instead ("rk8pd-pgifield": the
// comparison before issue 33). Timed runs watch nothing (best_of in problem.hpp); the errors of H and the Casimirs
// come from a monitored run of the same steps.
//
//   pgi_peers SCENE [--orders 2,4,6] [--realisations radial] [--jit] [--peers rk4imp,rk8pd,...] [--pgi-field PEERS]
//                   [--dts ...] [--tols ...] [--order K] [--dt DT] [--x0 A,B,...] [--t-end T] [--watch POLY]...
//                   [--csv FILE] [--plot FILE.svg] [--drift FILE] [--drift-t-end T2] [--long T3] [--suite]
//                   [--rhs-source FILE.c]
//
// Work-precision (default): pgi at each order, GSL rk2imp and rk4imp and odeint's rk4 on a step ladder
// (default 4 dt .. dt/8); GSL rk8pd, rkf45, msbdf and odeint's dopri5, Fehlberg 7(8) and Bulirsch-Stoer on a tolerance
// ladder (default 1e-4 .. 1e-12); final error against a long double Fehlberg 7(8) reference, whose own
// accuracy is estimated and printed (errors under 100 times it are marked unusable). Times are the best
// of up to 25 unmonitored runs (while they take under 0.3 s in all). --plot draws the work-precision diagram with
// gnuplot (tools/peers/plot.gp). Drift (--drift): relative energy and Casimir errors along a long run, pgi k = 4 and
// the peers. Long (--long T3): pgi k = 4 at the scene's dt to T3, then for each peer the cheapest run of its ladder
// whose maximum energy and Casimir errors are both at or below pgi's, or "none reaches them".
// Suite (--suite): one run of every method at the scene's order and dt (adaptive peers at tolerance
// --tol, default 1e-6) with its outcome: finished or why not, errors, watched quantities (final / initial).
#include "series/detail/child_process.hpp"
#include "series/message.hpp"
#include "tools/atomic_file.hpp"
#include "tools/exit_codes.hpp"
#include "tools/peers/methods.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <iostream>

#include <unistd.h>

namespace {

using namespace pgi::peers;
using nlohmann::json;

// pgi at each order (with the scene's realisation, then with each extra one), then the peers named
// (all of them if none is); an unknown name is an error.
// Each peer chosen that pgi_field names is followed by its twin fed pgi's field ("-pgifield").
std::vector<Method> select_methods(const std::vector<std::size_t>& orders,
                                   const std::vector<pgi::RealisationChoice>& extra,
                                   const std::vector<std::string>& names, bool jit,
                                   const std::vector<std::string>& pgi_field) {
    std::vector<Method> peers, chosen, fed;
    for (auto& m : gsl_methods()) peers.push_back(std::move(m));
    for (auto& m : odeint_methods()) peers.push_back(std::move(m));
    for (auto& m : gsl_methods(true)) fed.push_back(std::move(m));
    for (auto& m : odeint_methods(true)) fed.push_back(std::move(m));
    const auto check = [&](const std::vector<std::string>& list, const std::string& option) {
        for (const auto& name : list)
            if (std::none_of(peers.begin(), peers.end(), [&](const Method& m) { return m.name == name; })) {
                std::string known;
                for (const auto& m : peers) known += " " + m.name;
                throw std::invalid_argument(option + ": unknown peer '" + name + "' (known:" + known + ")");
            }
    };
    check(names, "--peers");
    check(pgi_field, "--pgi-field");
    const auto named = [](const std::vector<std::string>& list, const std::string& name) {
        return std::find(list.begin(), list.end(), name) != list.end();
    };
    for (std::size_t k : orders) chosen.push_back(pgi_method(k));
    if (jit)
        for (std::size_t k : orders) chosen.push_back(pgi_method(k, std::nullopt, true));
    for (auto r : extra)
        for (std::size_t k : orders) chosen.push_back(pgi_method(k, r));
    for (std::size_t i = 0; i < peers.size(); ++i) {
        const std::string name = peers[i].name;
        if (names.empty() || named(names, name)) chosen.push_back(std::move(peers[i]));
        if (named(pgi_field, name)) chosen.push_back(std::move(fed[i]));
    }
    return chosen;
}

// The values each kind of method runs at: steps for fixed-step methods, tolerances for adaptive ones.
struct Ladders {
    std::vector<double> steps, tolerances;
    const std::vector<double>& of(const Method& m) const { return m.fixed_step ? steps : tolerances; }
};

json outcome_json(const Outcome& o) {
    return {{"seconds", o.seconds},
            {"steps", o.steps},
            {"evaluations", o.evaluations},
            {"energy_error_max", o.energy_error},
            {"casimir_error_max", o.casimir_error},
            {"watched_final_over_initial", o.watched},
            {"ok", o.ok},
            {"failure", o.failure},
            {"setup_seconds", o.setup_seconds},
            {"native_maps", o.native_maps}};
}

void log_outcome(const std::string& label, const std::string& parameter, const Outcome& o,
                 double error = std::nan("")) {
    const std::string err = std::isnan(error) ? "" : fmt::format("error {:9.2e}", error);
    std::cerr << fmt::format("{:14s} {:>12s}: {:15s}  {:9.4f} s  {:9d} steps  energy {:8.1e}  Casimir {:8.1e}{}\n",
                             label, parameter, err, o.seconds, o.steps, o.energy_error, o.casimir_error,
                             o.ok ? "" : "  FAILED: " + o.failure);
}

bool is_pgi(const Method& m) {
    return m.name.rfind("pgi-", 0) == 0;
}

std::string parameter(const Method& m, double value) {
    return fmt::format("{}={:g}", m.fixed_step ? "dt" : "tol", value);
}

// Time a method needs for a given error, by log-log interpolation along its ladder (NaN if out of range).
double time_at_error(const std::vector<json>& rows, const std::string& method, double error) {
    std::vector<std::pair<double, double>> pts;  // (log error, log time)
    for (const auto& r : rows)
        if (r["method"] == method && r["usable"].get<bool>())
            pts.emplace_back(std::log(r["error"].get<double>()), std::log(r["seconds"].get<double>()));
    std::sort(pts.begin(), pts.end());
    const double le = std::log(error);
    for (std::size_t i = 0; i + 1 < pts.size(); ++i)
        if (pts[i].first <= le && le <= pts[i + 1].first) {
            const double w = (le - pts[i].first) / (pts[i + 1].first - pts[i].first);
            return std::exp(pts[i].second + w * (pts[i + 1].second - pts[i].second));
        }
    return std::nan("");
}

// For each pgi order and each peer: the median, over pgi's usable points, of peer time / pgi time at
// pgi's error (null where the peer's ladder does not reach it).
json matched_error_ratios(const std::vector<json>& rows, const std::vector<Method>& methods) {
    json out;
    for (const auto& p : methods) {
        if (!is_pgi(p)) continue;
        for (const auto& q : methods) {
            if (is_pgi(q)) continue;
            std::vector<double> ratios;
            for (const auto& r : rows)
                if (r["method"] == p.name && r["usable"].get<bool>()) {
                    const double peer = time_at_error(rows, q.name, r["error"].get<double>());
                    if (std::isfinite(peer)) ratios.push_back(peer / r["seconds"].get<double>());
                }
            std::sort(ratios.begin(), ratios.end());
            out[p.name][q.name] = ratios.empty() ? json() : json(ratios[ratios.size() / 2]);
        }
    }
    return out;
}

json work_precision(const Problem& pr, const std::vector<Method>& methods, const Ladders& ladders, const State& x0,
                    double T, const std::string& csv_file) {
    // the reference and its accuracy, estimated as its distance to the same method at a 10x looser tolerance
    const auto t0 = Clock::now();
    const State ref = reference_solution(pr, x0, T, 1e-18L);
    const double ref_accuracy = std::max(distance(ref, reference_solution(pr, x0, T, 1e-17L)), 1e-17);
    std::cerr << fmt::format(
        "reference: Fehlberg 7(8) in long double, relative tolerance 1e-18; accuracy {:.1e} ({:.2f} s)\n", ref_accuracy,
        std::chrono::duration<double>(Clock::now() - t0).count());
    std::vector<json> rows;
    for (const auto& m : methods)
        for (double v : ladders.of(m)) {
            const Outcome o = best_of(m, pr, x0, T, v);
            const double err = o.ok ? distance(o.x, ref) : std::nan("");
            log_outcome(m.name, parameter(m, v), o, err);
            json row = outcome_json(o);
            row.update({{"method", m.name},
                        {"parameter", parameter(m, v)},
                        {"error", o.ok ? json(err) : json()},
                        {"usable", o.ok && err >= 100 * ref_accuracy}});
            rows.push_back(row);
        }
    if (!csv_file.empty()) {
        pgi::AtomicFile f(csv_file);
        f.stream() << "method,parameter,error,seconds,steps,evaluations,energy_error,casimir_error,usable\n";
        for (const auto& r : rows)
            f.stream() << fmt::format("{},{},{:.6e},{:.6e},{},{},{:.6e},{:.6e},{}\n", r["method"].get<std::string>(),
                                      r["parameter"].get<std::string>(),
                                      r["error"].is_null() ? std::nan("") : r["error"].get<double>(),
                                      r["seconds"].get<double>(), r["steps"].get<std::size_t>(),
                                      r["evaluations"].get<std::size_t>(), r["energy_error_max"].get<double>(),
                                      r["casimir_error_max"].get<double>(), r["usable"].get<bool>() ? 1 : 0);
        f.commit();
    }
    return {{"t_end", T},
            {"reference", {{"method", "Fehlberg 7(8), long double, tol 1e-18"}, {"accuracy", ref_accuracy}}},
            {"matched_error_time_ratio_peer_over_pgi", matched_error_ratios(rows, methods)},
            {"rows", rows}};
}

// Long runs at the scene's dt (fixed steps) or at tolerance 1e-12 (adaptive), sampled for the drift plot.
json drift(const Problem& pr, const std::vector<Method>& methods, const State& x0, double T, const std::string& file) {
    json out = json::array();
    pgi::AtomicFile f(file);
    f.stream() << "method,t,energy_error,casimir_error\n";
    for (const auto& m : methods) {
        if (is_pgi(m) && m.name != "pgi-k4") continue;
        for (double v : {m.fixed_step ? pr.scene.dt : 1e-12}) {
            const std::string label = m.fixed_step ? m.name : fmt::format("{}-{:g}", m.name, v);
            Samples samples;
            const Outcome o = m.run(pr, x0, T, v, &samples);
            for (const auto& s : samples)
                f.stream() << fmt::format("{},{:.6e},{:.6e},{:.6e}\n", label, s[0], s[1], s[2]);
            log_outcome(label, fmt::format("T={:g}", T), o);
            json row = outcome_json(o);
            row["method"] = label;
            out.push_back(row);
        }
    }
    f.commit();
    return out;
}

// pgi k = 4 at the scene's dt to T, and for each peer the cheapest ladder run matching both of pgi's errors.
json long_table(const Problem& pr, const std::vector<Method>& methods, const State& x0, double T) {
    const Method pgi4 = pgi_method(4);
    const Outcome p = pgi4.run(pr, x0, T, pr.scene.dt, nullptr);
    log_outcome("pgi-k4", fmt::format("T={:g}", T), p);
    json table{{"t_end", T}, {"pgi-k4", outcome_json(p)}};
    for (const auto& m : methods) {
        if (is_pgi(m)) continue;
        json entry{{"matched", false}};
        const auto values = m.fixed_step ? std::vector<double>{pr.scene.dt, pr.scene.dt / 2, pr.scene.dt / 4}
                                         : std::vector<double>{1e-8, 1e-10, 1e-12, 1e-13};
        for (double v : values) {  // from the cheapest up: the first match is the cheapest
            const Outcome o = m.run(pr, x0, T, v, nullptr);
            log_outcome(m.name, parameter(m, v), o);
            json run = outcome_json(o);
            run["parameter"] = parameter(m, v);
            entry["runs"].push_back(run);
            if (o.ok && o.energy_error <= p.energy_error && o.casimir_error <= p.casimir_error) {
                entry.update({{"matched", true}, {"seconds", o.seconds}, {"parameter", parameter(m, v)}});
                break;
            }
        }
        table[m.name] = entry;
    }
    return table;
}

// Every method once, at the scene's order and dt (adaptive ones at tolerance tol), with its outcome.
json suite(const Problem& pr, const std::vector<Method>& methods, const State& x0, double T, double tol) {
    json rows = json::array();
    for (const auto& m : methods) {
        const double v = m.fixed_step ? pr.scene.dt : tol;
        const Outcome o = m.run(pr, x0, T, v, nullptr);
        log_outcome(m.name, parameter(m, v), o);
        json row = outcome_json(o);
        row.update({{"method", m.name}, {"parameter", parameter(m, v)}});
        rows.push_back(row);
    }
    return {{"t_end", T}, {"rows", rows}};
}

// The work-precision diagram from the CSV, by gnuplot and tools/peers/plot.gp, written beside svg and
// renamed into place. The script hands the CSV's path to awk through sh and gnuplot expands @macros even in
// quotes: a path or title with a quote, @, `, $, \\ or a control character is refused, never passed on. gnuplot runs
// as every child of pgi does (series/detail/child_process: no shell, its own process group, a time-out, bounded
// output). Throws if gnuplot is missing or fails.
void plot_work_precision(const std::string& csv, const std::string& svg, const std::string& title) {
    for (const auto* s : {&csv, &svg, &title})
        for (char c : *s)
            if (std::string_view("'@`$\\\"").find(c) != std::string_view::npos ||
                static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
                throw std::invalid_argument("--plot: '" + pgi::printable(*s) +
                                            "' holds a character gnuplot or sh would interpret");
    const std::string tmp = svg + ".tmp" + std::to_string(::getpid());
    pgi::TemporaryFile figure(tmp);
    const std::string vars = "kind='work-precision'; csv='" + csv + "'; out='" + tmp + "'; name='" + title + "'";
    const pgi::ChildResult r = pgi::run_child({"gnuplot", "-e", vars, PGI_PEERS_PLOT_SCRIPT});
    if (!r.ok())
        throw std::runtime_error("--plot: gnuplot " + r.failure + " on " + pgi::printable(csv) + ": " +
                                 pgi::output_tail(r.output) + " (Debian: gnuplot-nox)");
    std::filesystem::rename(tmp, svg);
    figure.keep();
}

}  // namespace

int main(int argc, char** argv) {
    std::signal(SIGPIPE, SIG_IGN);  // a closed pipe is a failed write (exit 6)
    pgi::remove_temporaries_on_signals();
    CLI::App app{
        "pgi_peers: pgi against GSL's and Boost.Odeint's integrators: work-precision, drift, long runs, outcomes"};
    std::string scene_file, csv_file, drift_file;
    pgi::SceneOverrides overrides;
    std::optional<double> t_end_opt;
    double drift_t_end = 1e4, long_t_end = 0;
    std::vector<std::string> watched_text;
    bool run_suite = false;
    double suite_tol = 1e-6;
    std::vector<std::size_t> orders{2, 4, 6};
    std::vector<std::string> peer_names;
    std::vector<double> dts, tols{1e-4, 1e-6, 1e-8, 1e-10, 1e-12};
    std::string plot_file;
    app.add_option("scene", scene_file)->required();
    app.add_option("--orders", orders, "pgi's orders k on the step ladder (default 2,4,6)")->delimiter(',');
    app.add_option(
           "--peers", peer_names,
           "the peers to run (default all: rk2imp,rk4imp,rk8pd,rkf45,msbdf,odeint-rk4,odeint-dopri5,odeint-rkf78,"
           "odeint-bs)")
        ->delimiter(',');
    app.add_option("--dts", dts, "the step ladder (default 4 dt, 2 dt, dt, dt/2, dt/4, dt/8)")->delimiter(',');
    app.add_option("--tols", tols, "the tolerance ladder (default 1e-4,1e-6,1e-8,1e-10,1e-12)")->delimiter(',');
    app.add_option("--plot", plot_file, "the work-precision diagram, an SVG drawn by gnuplot (needs --csv)");
    app.add_option("--order", overrides.order, "pgi's order k (suite)");
    std::vector<std::string> extra_realisations;
    app.add_option("--realisations", extra_realisations,
                   "pgi also with these realisations (closed-form, radial), e.g. radial")
        ->delimiter(',');
    app.add_option("--dt", overrides.dt, "the step (the ladders' middle)");
    app.add_option("--x0", overrides.x0, "the initial state, e.g. 1,2,0.5");
    app.add_option("--t-end", t_end_opt, "final time (default 100; the scene's t_end for --suite)");
    app.add_option("--watch", watched_text, "a polynomial whose final/initial ratio is reported (repeatable)");
    app.add_option("--csv", csv_file, "work-precision rows: method, parameter, error, seconds, ...");
    app.add_option("--drift", drift_file, "drift samples: method, t, energy error, Casimir error");
    app.add_option("--drift-t-end", drift_t_end, "final time of the drift runs (default 1e4)");
    app.add_option("--long", long_t_end, "the long-run table to this final time (e.g. 1e5)");
    bool jit = false;
    std::vector<std::string> pgi_field;
    std::string rhs_source_file;
    app.add_flag("--jit", jit,
                 "pgi also with its compiled maps as native code from the start (jit = always: pgi-k4-jit, the same "
                 "numbers)");
    app.add_option("--pgi-field", pgi_field,
                   "these peers also fed pgi's compiled field through pgi's interpreter (e.g. rk8pd: rk8pd-pgifield, "
                   "the comparison before issue 33)")
        ->delimiter(',');
    app.add_option("--rhs-source", rhs_source_file, "write the peers' generated C right-hand side to this file");
    app.add_flag("--suite", run_suite,
                 "one run of every method with its outcome, instead of the work-precision ladders");
    app.add_option("--tol", suite_tol, "the adaptive peers' tolerance in --suite (default 1e-6)");
    CLI11_PARSE(app, argc, argv);
    try {
        for (std::size_t k : orders)
            if (k < 1) throw std::invalid_argument("--orders: the order k must be at least 1");
        for (double v : dts)
            if (!(v > 0) || !std::isfinite(v))
                throw std::invalid_argument(fmt::format("--dts: {} is not a positive step", v));
        for (double v : tols)
            if (!(v > 0) || !std::isfinite(v))
                throw std::invalid_argument(fmt::format("--tols: {} is not a positive tolerance", v));
        if (!plot_file.empty() && csv_file.empty())
            throw std::invalid_argument("--plot draws from the --csv file: give both");
        // output paths are checked before hours of runs, not after (pgi's rules: directory, regular target, not the
        // scene)
        for (const auto& [option, path] : {std::pair<std::string, std::string>{"--csv", csv_file},
                                           {"--plot", plot_file},
                                           {"--drift", drift_file},
                                           {"--rhs-source", rhs_source_file}})
            if (!path.empty()) try {
                    pgi::check_output_path(path, {scene_file});
                } catch (const std::invalid_argument& e) {
                    throw std::invalid_argument(option + ": " + e.what());
                }
        std::vector<pgi::RealisationChoice> extra;
        for (const auto& r : extra_realisations) try {
                extra.push_back(pgi::parse_realisation_choice(r));
            } catch (const std::invalid_argument& e) {
                throw std::invalid_argument(std::string("--realisations: ") + e.what());
            }
        const pgi::Scene scene = pgi::load_scene(scene_file, overrides);
        pgi::require_valid(scene);
        if (!scene.x0) throw std::invalid_argument(scene_file + ": [run] x0 is needed (or --x0)");
        std::vector<pgi::Poly> watched;
        for (const auto& w : watched_text) watched.push_back(scene.phase_space().parse(w));
        // the peers' C right-hand side: its Jacobian only where an implicit peer runs (all peers run without --peers)
        const bool jacobian = peer_names.empty() || std::any_of(peer_names.begin(), peer_names.end(), needs_jacobian);
        const Problem pr(scene, watched, jacobian ? Problem::PeerRhs::field_and_jacobian : Problem::PeerRhs::field);
        if (!rhs_source_file.empty()) {
            pgi::AtomicFile f(rhs_source_file);
            f.stream() << pr.rhs.source;
            f.commit();
        }
        const State x0 = *scene.x0;
        json summary{{"scene", scene.name},
                     {"dt", scene.dt},
                     {"x0", x0},
                     {"watched", watched_text},
                     {"peer_rhs",
                      {{"language", "C, generated from the scene's exact polynomials"},
                       {"compiler", pr.rhs.command},
                       {"build_seconds", pr.rhs.build_seconds}}}};
        if (run_suite) {
            const auto methods = select_methods({scene.order}, extra, peer_names, jit, pgi_field);
            summary["suite"] = suite(pr, methods, x0, t_end_opt.value_or(scene.t_end.value_or(100.0)), suite_tol);
        } else {
            const double dt = scene.dt, T = t_end_opt.value_or(100.0);
            const Ladders ladders{dts.empty() ? std::vector<double>{4 * dt, 2 * dt, dt, dt / 2, dt / 4, dt / 8} : dts,
                                  tols};
            // a fixed step runs llround(T / dt) steps: one that does not divide T would end elsewhere, and its error
            // against the reference at T would be measured at another time
            for (double v : ladders.steps) {
                const double steps = std::round(T / v);
                if (!(steps >= 1) || std::abs(steps * v - T) > 1e-9 * T)
                    throw std::invalid_argument(fmt::format(
                        "{}: dt = {} does not divide the final time {} ({} steps end at t = {}); "
                        "give steps T / N",
                        dts.empty() ? "the scene's step ladder (4 dt .. dt/8)" : "--dts", v, T, steps, steps * v));
            }
            const auto methods = select_methods(orders, extra, peer_names, jit, pgi_field);
            summary["work_precision"] = work_precision(pr, methods, ladders, x0, T, csv_file);
            if (!plot_file.empty()) plot_work_precision(csv_file, plot_file, scene.name);
            if (!drift_file.empty()) summary["drift"] = drift(pr, methods, x0, drift_t_end, drift_file);
            if (long_t_end > 0) summary["long"] = long_table(pr, methods, x0, long_t_end);
        }
        std::cout << summary.dump(2) << "\n" << std::flush;
        if (!std::cout) throw pgi::OutputError("standard output: write failed");
    } catch (...) {
        return pgi::exit_code_of_current_exception("pgi_peers", "");
    }
    return 0;
}
