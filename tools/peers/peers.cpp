// pgi_peers: pgi against GSL's integrators on one scene, in one run (issue 5). Not part of the core
// library: only this program links GSL. The same compiled vector field (pi grad H, and its Jacobian for
// the implicit methods) feeds every peer, so the comparison measures the methods.
//
//   pgi_peers SCENE [--t-end T] [--csv FILE] [--drift FILE] [--drift-t-end T2] [--long T3]
//
// Work-precision: pgi k = 2, 4, 6 and GSL's rk4imp (Gauss, order 4) on a step ladder, GSL's rk8pd,
// rkf45 and msbdf on a tolerance ladder; final error against a reference (rk8pd at tolerance 1e-13, its
// own accuracy estimated against tolerance 1e-12 and printed; errors under 100 times it are not used).
// Drift: relative energy and Casimir errors along a long run for pgi k = 4 and the peers.
// Long (--long T3): pgi k = 4 at the scene's dt to T3, then for each peer the cheapest run of its ladder
// whose maximum energy and Casimir errors are both at or below pgi's, or "none reaches them".
#include "poisson/integrate.hpp"
#include "tools/atomic_file.hpp"
#include "tools/scene.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

namespace {

using Clock = std::chrono::steady_clock;
using pgi::CompiledMap;

struct Problem {
    const pgi::Scene& scene;
    CompiledMap field, jacobian, invariants;  // invariants: H, then the Casimirs
    std::size_t n;
    explicit Problem(const pgi::Scene& s) : scene(s), n(s.phase_space().dim()) {
        const auto xs = s.phase_space().coordinate_vars();
        auto f = s.pi.hamiltonian_vector_field(s.H);
        std::vector<pgi::Poly> J;  // row-major, as GSL wants dfdy
        for (const auto& fi : f)
            for (std::size_t j = 0; j < n; ++j) J.push_back(pgi::derivative(fi, xs[j]));
        std::vector<pgi::Poly> inv{s.H};
        inv.insert(inv.end(), s.casimirs.begin(), s.casimirs.end());
        field = CompiledMap::build(f, xs);
        jacobian = CompiledMap::build(J, xs);
        invariants = CompiledMap::build(inv, xs);
    }
};

int rhs(double, const double y[], double dydt[], void* p) {
    static_cast<Problem*>(p)->field.eval(y, dydt);
    return GSL_SUCCESS;
}
int jac(double, const double y[], double* dfdy, double dfdt[], void* p) {
    auto* pr = static_cast<Problem*>(p);
    pr->jacobian.eval(y, dfdy);
    for (std::size_t i = 0; i < pr->n; ++i) dfdt[i] = 0.0;
    return GSL_SUCCESS;
}

// Tracks the largest relative error of each invariant, and optionally samples it for the drift plot.
struct Monitor {
    const Problem& pr;
    std::vector<double> initial, value, worst;
    std::vector<std::array<double, 3>>* samples = nullptr;  // t, energy error, first Casimir error
    double next_sample = 0;
    explicit Monitor(const Problem& p, const double* x0) : pr(p), initial(p.invariants.num_outputs()), value(initial), worst(initial.size(), 0.0) {
        pr.invariants.eval(x0, initial.data());
    }
    void operator()(double t, const double* x) {
        pr.invariants.eval(x, value.data());
        for (std::size_t i = 0; i < value.size(); ++i)
            worst[i] = std::max(worst[i], std::abs(value[i] - initial[i]) / std::max(std::abs(initial[i]), 1e-300));
        if (samples && t >= next_sample) {
            samples->push_back({t, std::abs(value[0] - initial[0]) / std::abs(initial[0]),
                                value.size() > 1 ? std::abs(value[1] - initial[1]) / std::abs(initial[1]) : 0.0});
            next_sample = next_sample == 0 ? t * 1.05 + 1e-9 : next_sample * 1.05;  // log-spaced in t
        }
    }
    // the largest relative errors seen: of H, and of the worst Casimir (0 without Casimirs)
    double energy_error() const { return worst[0]; }
    double casimir_error() const { return worst.size() > 1 ? *std::max_element(worst.begin() + 1, worst.end()) : 0.0; }
};

struct Outcome {
    std::vector<double> x;
    double seconds = 0, energy_error = 0, casimir_error = 0;
    std::size_t steps = 0;
    bool ok = true;
};

Outcome run_gsl(Problem& pr, const gsl_odeiv2_step_type* type, const std::vector<double>& x0, double T, double h, double eps,
                bool fixed, std::vector<std::array<double, 3>>* samples = nullptr) {
    gsl_odeiv2_system sys{rhs, jac, pr.n, &pr};
    // NOTE: GSL's implicit steppers (rk4imp, msbdf) work only through a driver, which owns step, control and evolve.
    gsl_odeiv2_driver* d = fixed ? gsl_odeiv2_driver_alloc_y_new(&sys, type, h, 1e-14, 1e-14)
                                 : gsl_odeiv2_driver_alloc_y_new(&sys, type, h, eps, eps);
    if (d == nullptr) throw std::runtime_error("GSL driver");
    Outcome o;
    o.x = x0;
    Monitor monitor(pr, x0.data());
    monitor.samples = samples;
    double t = 0;
    const auto start = Clock::now();
    const auto N = static_cast<std::size_t>(std::llround(T / h));
    while (fixed ? o.steps < N : t < T) {
        int status = fixed ? gsl_odeiv2_evolve_apply_fixed_step(d->e, nullptr, d->s, &sys, &t, h, o.x.data())
                           : gsl_odeiv2_evolve_apply(d->e, d->c, d->s, &sys, &t, T, &h, o.x.data());
        if (status != GSL_SUCCESS) {
            o.ok = false;
            break;
        }
        ++o.steps;
        monitor(t, o.x.data());
    }
    o.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    o.energy_error = monitor.energy_error();
    o.casimir_error = monitor.casimir_error();
    gsl_odeiv2_driver_free(d);
    return o;
}

Outcome run_pgi(Problem& pr, std::size_t k, const std::vector<double>& x0, double T, double dt,
                std::vector<std::array<double, 3>>* samples = nullptr) {
    pgi::StepOptions opt;
    opt.k = k;
    opt.dt = dt;
    Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(x0.data(), Eigen::Index(x0.size()));
    auto st = pgi::NewtonStepper::build(pr.scene.pi, pr.scene.H, opt, x);
    Outcome o;
    Monitor monitor(pr, x0.data());
    monitor.samples = samples;
    const auto N = static_cast<std::size_t>(std::llround(T / dt));
    const auto start = Clock::now();
    auto summary = pgi::integrate_steps(st, x, N, [&](std::size_t, double t, const Eigen::VectorXd& y) {
        monitor(t, y.data());
        return false;
    });
    o.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    o.ok = summary.status == pgi::StepStatus::ok;
    o.steps = summary.steps;
    o.x.assign(x.data(), x.data() + x.size());
    o.energy_error = monitor.energy_error();
    o.casimir_error = monitor.casimir_error();
    return o;
}

double distance(const std::vector<double>& a, const std::vector<double>& b) {
    double d = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
    return d;
}

// Time a method needs for a given error, by log-log interpolation along its ladder (NaN if out of range).
double time_at_error(const std::vector<nlohmann::json>& rows, const std::string& method, double error) {
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

// pgi k = 4 at dt to T, and for each peer the cheapest ladder run matching both of pgi's maximum errors.
nlohmann::json long_table(Problem& pr, const std::vector<double>& x0, double dt, double T) {
    const Outcome p = run_pgi(pr, 4, x0, T, dt);
    nlohmann::json table{{"t_end", T},
                         {"pgi-k4", {{"seconds", p.seconds}, {"energy_error_max", p.energy_error}, {"casimir_error_max", p.casimir_error}}}};
    std::cerr << fmt::format("long T = {:g}: pgi-k4 {:.2f} s, energy {:.1e}, Casimir {:.1e}\n", T, p.seconds, p.energy_error, p.casimir_error);
    auto matches = [&](const Outcome& o) { return o.ok && o.energy_error <= p.energy_error && o.casimir_error <= p.casimir_error; };
    struct Ladder {
        std::string name;
        const gsl_odeiv2_step_type* type;
        bool fixed;
        std::vector<double> values;  // steps (fixed) or tolerances
    };
    const std::vector<Ladder> ladders{{"rk4imp", gsl_odeiv2_step_rk4imp, true, {dt, dt / 2, dt / 4}},
                                      {"rk8pd", gsl_odeiv2_step_rk8pd, false, {1e-8, 1e-10, 1e-12, 1e-13}},
                                      {"rkf45", gsl_odeiv2_step_rkf45, false, {1e-8, 1e-10, 1e-12}},
                                      {"msbdf", gsl_odeiv2_step_msbdf, false, {1e-8, 1e-10, 1e-12}}};
    for (const auto& l : ladders) {
        nlohmann::json entry{{"matched", false}};
        for (double v : l.values) {  // from the cheapest up: the first match is the cheapest
            const Outcome o = run_gsl(pr, l.type, x0, T, l.fixed ? v : 1e-3, l.fixed ? 0.0 : v, l.fixed);
            std::cerr << fmt::format("long T = {:g}: {} {}={:g}: {:.2f} s, energy {:.1e}, Casimir {:.1e}{}\n", T, l.name,
                                     l.fixed ? "dt" : "tol", v, o.seconds, o.energy_error, o.casimir_error, o.ok ? "" : " FAILED");
            entry["runs"].push_back({{l.fixed ? "dt" : "tol", v}, {"seconds", o.seconds}, {"energy_error_max", o.energy_error},
                                     {"casimir_error_max", o.casimir_error}, {"ok", o.ok}});
            if (matches(o)) {
                entry["matched"] = true;
                entry["seconds"] = o.seconds;
                entry[l.fixed ? "dt" : "tol"] = v;
                break;
            }
        }
        table[l.name] = entry;
    }
    return table;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"pgi_peers: pgi against GSL's integrators, work-precision and drift"};
    std::string scene_file, csv_file, drift_file;
    double t_end = 100, drift_t_end = 1e4;
    app.add_option("scene", scene_file)->required();
    app.add_option("--t-end", t_end, "final time of the work-precision runs (default 100)");
    app.add_option("--csv", csv_file, "work-precision rows: method, parameter, error, seconds, ...");
    app.add_option("--drift", drift_file, "drift samples: method, t, energy error, Casimir error");
    app.add_option("--drift-t-end", drift_t_end, "final time of the drift runs (default 1e4)");
    double long_t_end = 0;
    app.add_option("--long", long_t_end, "also the long-run table to this final time (e.g. 1e5)");
    CLI11_PARSE(app, argc, argv);
    gsl_set_error_handler_off();
    const pgi::Scene scene = pgi::load_scene(scene_file);
    Problem pr(scene);
    const std::vector<double> x0 = *scene.x0;

    // reference, with its own accuracy estimated from the next tolerance up
    const Outcome ref = run_gsl(pr, gsl_odeiv2_step_rk8pd, x0, t_end, 1e-3, 1e-13, false);
    const Outcome ref_check = run_gsl(pr, gsl_odeiv2_step_rk8pd, x0, t_end, 1e-3, 1e-12, false);
    const double ref_accuracy = std::max(distance(ref.x, ref_check.x), 1e-16);

    std::vector<nlohmann::json> rows;
    auto add = [&](const std::string& method, const std::string& parameter, const Outcome& o) {
        const double err = distance(o.x, ref.x);
        rows.push_back({{"method", method}, {"parameter", parameter}, {"error", err}, {"seconds", o.seconds},
                        {"steps", o.steps}, {"energy_error", o.energy_error}, {"casimir_error", o.casimir_error},
                        {"ok", o.ok}, {"usable", o.ok && err >= 100 * ref_accuracy}});
        std::cerr << fmt::format("{:8s} {:>10s}: error {:9.2e}  {:9.4f} s  {:8d} steps  energy {:8.1e}  Casimir {:8.1e}{}\n", method,
                                 parameter, err, o.seconds, o.steps, o.energy_error, o.casimir_error, o.ok ? "" : "  FAILED");
    };
    for (double factor : {4.0, 2.0, 1.0, 0.5, 0.25, 0.125}) {
        const double dt = scene.dt * factor;
        for (std::size_t k : {2, 4, 6}) add(fmt::format("pgi-k{}", k), fmt::format("dt={:g}", dt), run_pgi(pr, k, x0, t_end, dt));
        add("rk4imp", fmt::format("dt={:g}", dt), run_gsl(pr, gsl_odeiv2_step_rk4imp, x0, t_end, dt, 0, true));
    }
    for (double eps : {1e-4, 1e-6, 1e-8, 1e-10, 1e-11}) {
        add("rk8pd", fmt::format("tol={:g}", eps), run_gsl(pr, gsl_odeiv2_step_rk8pd, x0, t_end, 1e-3, eps, false));
        add("rkf45", fmt::format("tol={:g}", eps), run_gsl(pr, gsl_odeiv2_step_rkf45, x0, t_end, 1e-3, eps, false));
        add("msbdf", fmt::format("tol={:g}", eps), run_gsl(pr, gsl_odeiv2_step_msbdf, x0, t_end, 1e-3, eps, false));
    }
    // pgi k = 4 against rk4imp at matched error: the median time ratio over pgi's usable points
    std::vector<double> ratios;
    for (const auto& r : rows)
        if (r["method"] == "pgi-k4" && r["usable"].get<bool>()) {
            const double peer = time_at_error(rows, "rk4imp", r["error"].get<double>());
            if (std::isfinite(peer)) ratios.push_back(peer / r["seconds"].get<double>());
        }
    std::sort(ratios.begin(), ratios.end());
    nlohmann::json summary{{"scene", scene.name}, {"t_end", t_end}, {"reference_accuracy", ref_accuracy},
                           {"rk4imp_over_pgi4_at_matched_error", ratios.empty() ? nlohmann::json() : nlohmann::json(ratios[ratios.size() / 2])},
                           {"rows", rows}};
    if (!csv_file.empty()) {
        pgi::AtomicFile f(csv_file);
        f.stream() << "method,parameter,error,seconds,steps,energy_error,casimir_error,usable\n";
        for (const auto& r : rows)
            f.stream() << fmt::format("{},{},{:.6e},{:.6e},{},{:.6e},{:.6e},{}\n", r["method"].get<std::string>(),
                                      r["parameter"].get<std::string>(), r["error"].get<double>(), r["seconds"].get<double>(),
                                      r["steps"].get<std::size_t>(), r["energy_error"].get<double>(),
                                      r["casimir_error"].get<double>(), r["usable"].get<bool>() ? 1 : 0);
        f.commit();
    }
    if (!drift_file.empty()) {
        // long runs at the scene's dt (pgi, rk4imp) and at tolerances giving a similar short-time error
        nlohmann::json drift = nlohmann::json::array();
        pgi::AtomicFile f(drift_file);
        f.stream() << "method,t,energy_error,casimir_error\n";
        auto sampled = [&](const std::string& method, auto run) {
            std::vector<std::array<double, 3>> samples;
            Outcome o = run(&samples);
            for (const auto& s : samples) f.stream() << fmt::format("{},{:.6e},{:.6e},{:.6e}\n", method, s[0], s[1], s[2]);
            drift.push_back({{"method", method}, {"seconds", o.seconds}, {"energy_error_max", o.energy_error},
                             {"casimir_error_max", o.casimir_error}, {"ok", o.ok}});
            std::cerr << fmt::format("drift {:10s} T = {:g}: {:8.3f} s, energy {:8.1e}, Casimir {:8.1e}{}\n", method, drift_t_end,
                                     o.seconds, o.energy_error, o.casimir_error, o.ok ? "" : "  FAILED");
        };
        sampled("pgi-k4", [&](auto* s) { return run_pgi(pr, 4, x0, drift_t_end, scene.dt, s); });
        sampled("rk4imp", [&](auto* s) { return run_gsl(pr, gsl_odeiv2_step_rk4imp, x0, drift_t_end, scene.dt, 0, true, s); });
        for (double eps : {1e-8, 1e-12}) {
            sampled(fmt::format("rk8pd-{:g}", eps), [&](auto* s) { return run_gsl(pr, gsl_odeiv2_step_rk8pd, x0, drift_t_end, 1e-3, eps, false, s); });
            sampled(fmt::format("msbdf-{:g}", eps), [&](auto* s) { return run_gsl(pr, gsl_odeiv2_step_msbdf, x0, drift_t_end, 1e-3, eps, false, s); });
        }
        f.commit();
        summary["drift"] = drift;
        summary["drift_t_end"] = drift_t_end;
    }
    if (long_t_end > 0) summary["long"] = long_table(pr, x0, scene.dt, long_t_end);
    summary.erase("rows");
    std::cout << summary.dump(2) << "\n";
    return 0;
}
