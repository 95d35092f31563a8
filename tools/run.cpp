// pgi step and pgi integrate: a scene's numerical run, observed and summarised.
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"
#include "tools/csv.hpp"

#include "scheme/run_loop.hpp"
#include "scheme/detail/time_output.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <iostream>

namespace pgi {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

const std::vector<double>& require_x0(const Scene& scene) {
    if (!scene.x0) throw SceneError(scene.file, "run.x0", "missing: give [run] x0 or --x0");
    return *scene.x0;
}

Eigen::VectorXd to_vector(const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

NewtonStepper build_stepper(const Scene& scene) {
    NewtonStepper s =
        scene.scheme->stepper(scene.dt, to_vector(require_x0(scene)));  // the scheme carries k, realisation, jit
    // NOTE: said on stderr, never silently: past the series' range the step is not Poisson to round-off.
    // (an infinite estimate: the terms' sizes did not decay through the degrees measured; JSON writes it as null)
    if (const double left = s.info().truncation_estimate; left > 1e-15)
        say(fmt::format(
            "pgi: {}: warning: the {} realisation truncated at p-degree {} leaves terms of relative size {} at x0's "
            "magnitudes: the step is Poisson only to that accuracy (reduce dt)",
            scene.file.string(), s.info().method, s.info().degree,
            std::isfinite(left) ? fmt::format("{:.1e}", left) : std::string("unknown (no decay seen)")));
    return s;
}

// NOTE: said on stderr and in the JSON document (energy_warning), never silently: exit 0 with H off by a tenth or more.
void warn_energy_drift(const Scene& scene, double energy_error, json& r) {
    const bool drifted = energy_drifted(energy_error);
    r["energy_warning"] = drifted;
    if (!drifted) return;
    say(
        fmt::format("pgi: {}: warning: the relative energy error reached {:.2e} (above {}): every step solved its "
                    "equation, but at dt = {} order {} does not follow the flow of H (reduce dt or raise the order)",
                    scene.file.string(), energy_error, energy_warning_from, scene.dt, scene.order));
}

// NOTE: said on stderr (one line) and in the JSON document (native_failure): by default native code is built in the
// background of a long run, and without a compiler the run goes on with machine code (or interpreted), with the same
// numbers.
void note_native_failure(const Scene& scene, const NewtonStepper& s, json& r) {
    if (s.native_failure().empty()) return;
    const std::string why = s.native_failure().substr(0, s.native_failure().find('\n'));
    r["native_failure"] = why;
    say(fmt::format("pgi: {}: note: native code could not be built, the run went on without it: {}",
                    scene.file.string(), why));
}

json stepper_info(const Scene& scene, const NewtonStepper& s) {
    return {{"order", scene.order},
            {"realisation", s.info().method},
            {"degree", s.info().degree},
            {"exact_realisation", s.info().exact_realisation},
            {"truncation_estimate", s.info().truncation_estimate},
            {"method_order", s.order()},
            {"predictor_order", s.info().predictor_order},
            {"native_maps", s.native_maps()},
            {"machine_code_maps", s.info().machine_code_maps},
            {"hessian_terms", s.info().hessian_terms}};
}

// A one-line progress indication on a terminal, for runs longer than about a second and a half.
class Progress {
public:
    Progress(bool enabled, std::size_t total) : enabled_(enabled && ::isatty(2)), total_(total), start_(Clock::now()) {}
    ~Progress() {
        if (shown_) std::cerr << "\r\033[K" << std::flush;
    }
    void update(std::size_t n) {
        if (!enabled_ || (n & 1023) != 0) return;
        auto now = Clock::now();
        if (now - start_ < std::chrono::milliseconds(1500) || now - last_ < std::chrono::milliseconds(250)) return;
        last_ = now;
        shown_ = true;
        std::cerr << fmt::format("\rpgi: step {} of {} ({:.0f}%)", n, total_, 100.0 * double(n) / double(total_))
                  << std::flush;
    }

private:
    bool enabled_, shown_ = false;
    std::size_t total_;
    Clock::time_point start_, last_{};
};

}  // namespace

CompiledMap invariants(const Scene& scene, const std::vector<Poly>& extra) {
    return scene.scheme->invariants(extra);
}

std::vector<double> invariant_scales(const Scene& scene, const std::vector<double>& x, const std::vector<Poly>& extra) {
    return invariant_scales(*scene.scheme, x, extra);
}

std::string failure_message(const NewtonStepper& s, std::size_t step, StepStatus status) {
    return step_failure_message(s, step, status);
}

std::size_t step_count(const Scene& scene, std::size_t max_steps, std::size_t event_samples) {
    if (!scene.t_end) throw SceneError(scene.file, "run.t_end", "missing: give [run] t_end or --t-end");
    RunRequest request;
    request.dt = scene.dt;
    request.t_end = *scene.t_end;
    request.event_samples = event_samples;
    request.every = 0;  // the run streams what it records: its CSV has a budget of its own (--max-csv-mb)
    RunLimits limits;
    limits.max_steps = max_steps;
    try {
        return plan_run(request, limits).steps;
    } catch (const RunBudgetError& e) {
        throw RunBudgetError(scene.file.string() + ": " + e.what());
    }
}

namespace {

// The scene's Casimirs as text, in the order of casimir_error_max.
std::vector<std::string> casimir_texts(const Scene& scene) {
    std::vector<std::string> texts;
    for (const Poly& c : scene.casimirs) texts.push_back(c.to_string());
    return texts;
}

// "x1^2 + x2^2 + x3^2" for a scene's only Casimir, "C2 = x2*x4*x6" for the second of several; at most 60
// characters of the polynomial (then "...").
std::string casimir_label(const json& texts, std::size_t i) {
    std::string text = texts[i].get<std::string>();
    if (text.size() > 60) text = text.substr(0, 57) + "...";
    return texts.size() == 1 ? text : fmt::format("C{} = {}", i + 1, text);
}

// Each Casimir's fitted error slope per step (RunLoop::drift_per_step, H's entry and the extras' left out).
std::vector<double> casimir_drift(const RunLoop& loop, std::size_t casimirs) {
    const std::vector<double> drift = loop.drift_per_step();
    return {drift.begin() + 1, drift.begin() + 1 + long(casimirs)};
}

// The coordinates of an extended state (x, w) (the scene's parameters' values w after them).
std::vector<double> coordinates_of(const Scene& scene, const Eigen::VectorXd& x) {
    return {x.data(), x.data() + scene.dim()};
}

// The run's parameter values by name, for the JSON report (none: no key).
void add_parameters(const Scene& scene, json& r) {
    if (scene.parameters.empty()) return;
    json w = json::object();
    for (std::size_t a = 0; a < scene.parameters.size(); ++a) w[scene.parameters[a].name] = scene.parameter_values[a];
    r["parameters"] = w;
}

}  // namespace

json step_report(const Scene& scene) {
    NewtonStepper s = build_stepper(scene);
    Eigen::VectorXd x = to_vector(require_x0(scene)), increment(x.size());
    StepStatus status = s.step(x, increment);
    if (status == StepStatus::ok && !(x + increment).allFinite()) status = StepStatus::non_finite;
    if (status != StepStatus::ok) {
        const std::string message = failure_message(s, 1, status);
        throw NumericalFailure(message, {{"status", "step_failed"},
                                         {"failure", message},
                                         {"steps", 0},
                                         {"t", 0.0},
                                         {"x", coordinates_of(scene, x)},
                                         {"dt", scene.dt}});
    }
    const int iterations = s.last_iterations();
    const double correction = s.last_correction();
    json r{{"status", "ok"},
           {"x", coordinates_of(scene, x + increment)},
           {"newton_iterations", iterations},
           {"residual", s.residual_at_solution(x)},
           {"correction", correction},
           {"dt", scene.dt}};
    r.update(stepper_info(scene, s));
    add_parameters(scene, r);
    return r;
}

// The CSV's row at t: t, the coordinates, H and the Casimirs (values: the loop's at that state).
void write_row(std::ostream& out, const Scene& scene, double t, const Eigen::VectorXd& x,
               const std::vector<double>& values) {
    out << csv_number(t);
    for (Eigen::Index i = 0; i < Eigen::Index(scene.dim()); ++i) out << ',' << csv_number(x[i]);
    for (std::size_t i = 0; i < 1 + scene.casimirs.size(); ++i) out << ',' << csv_number(values[i]);
    out << "\n";
}

json integrate_report(const Scene& scene, const IntegrateOptions& options) {
    const std::size_t N = step_count(scene, options.max_steps);
    std::optional<TimeOutput> times;  // --t-eval: the times checked as every surface checks them (plan_run)
    if (!options.t_eval.empty()) {
        RunRequest request;
        request.dt = scene.dt, request.t_end = *scene.t_end, request.dim = scene.dim(), request.t_eval = options.t_eval;
        RunLimits limits;
        limits.max_steps = options.max_steps;
        (void)plan_run(request, limits);
        times.emplace(options.t_eval, scene.dt);
    }
    const std::vector<Poly> extra = options.modified ? std::vector<Poly>{*options.modified} : std::vector<Poly>{};
    std::optional<AtomicFile> csv;
    if (options.csv) {
        // at most 25 characters a number: refuse before running rather than fill the disk
        const double rows = times ? double(options.t_eval.size()) : double(N / options.every + 2),
                     columns = double(2 + scene.dim() + scene.casimirs.size());
        const double mb = rows * columns * 25 / 1e6;
        if (!(mb <= options.max_csv_mb))
            throw BudgetError(
                fmt::format("{}: --csv: the trajectory would take about {:.3g} MB ({:.0f} rows of {:.0f} columns), "
                            "above the limit of {:.3g} MB: raise --every or --max-csv-mb",
                            scene.file.string(), mb, rows, columns, options.max_csv_mb));
        csv.emplace(*options.csv, std::vector<std::filesystem::path>{scene.file});
    }
    const auto built = Clock::now();
    NewtonStepper s = build_stepper(scene);
    const double build_seconds = std::chrono::duration<double>(Clock::now() - built).count();
    RunLoop loop(*scene.scheme, extra, {"Htilde"});
    if (csv) {
        csv->stream() << "t";
        for (const auto& c : scene.scheme->coordinates()) csv->stream() << "," << c;
        csv->stream() << ",H";
        for (std::size_t c = 0; c < scene.casimirs.size(); ++c) csv->stream() << ",C" << c + 1;
        csv->stream() << "\n";
    }
    Progress progress(options.progress, N);
    Eigen::VectorXd x = to_vector(require_x0(scene));
    const auto start = Clock::now();
    // the observer: what the command line does with each state (the loop is the library's, scheme/run_loop)
    StepStatus output = StepStatus::ok;  // of --t-eval's partial steps
    const auto timed_row = [&](const TimeRow& row) {
        if (!loop.observe_between(row.x)) return false;
        write_row(csv->stream(), scene, row.t, row.x, loop.values());
        return true;
    };
    const RunEnd end = loop.run(s, x, N, [&](const RunPoint& p) {
        if (options.observe) options.observe(p.step, p.t, p.x, loop.values());
        if (csv && times) {
            output = times->observe(s, p.step, p.t, p.x, timed_row);
            if (output != StepStatus::ok) return true;
        } else if (csv && records_step(p.step, p.step == N, options.every)) {
            write_row(csv->stream(), scene, p.t, p.x, loop.values());
        }
        progress.update(p.step);
        return false;
    });
    if (csv && times && end.ok() && !end.stopped) output = times->finish(s, timed_row);
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    const std::vector<double>& worst = loop.error_max();
    std::vector<double> casimir_errors(worst.begin() + 1, worst.begin() + 1 + long(scene.casimirs.size()));
    json r{{"status", "ok"},
           {"steps", end.steps},
           {"t", double(end.steps) * scene.dt},
           {"x", coordinates_of(scene, x)},
           {"energy_error_max", worst[0]},
           {"casimirs", casimir_texts(scene)},
           {"casimir_error_max", casimir_errors},
           {"casimir_drift_per_step", casimir_drift(loop, scene.casimirs.size())},
           {"newton_iterations_mean", end.mean_iterations},
           {"wall_seconds", wall},
           {"build_seconds", build_seconds},
           {"ns_per_step", wall / double(std::max<std::size_t>(end.steps, 1)) * 1e9},
           {"dt", scene.dt},
           {"t_end", *scene.t_end}};
    if (options.modified) r["modified_energy_error_max"] = worst.back();
    r.update(stepper_info(scene, s));
    add_parameters(scene, r);
    note_native_failure(scene, s, r);
    if (end.ok()) warn_energy_drift(scene, worst[0], r);
    if (output != StepStatus::ok) {  // a partial step to a requested time (or its invariants) failed
        const std::string message = times->failure_message(s, output, loop.non_finite());
        csv->stream() << "# INCOMPLETE: " << message << "\n";
        csv->commit();
        r["status"] = "step_failed";
        r["failure"] = message;
        r["residual"] = s.last_residual();
        throw NumericalFailure(message, r);
    }
    if (!end.ok()) {
        std::string message = loop.failure_message(s, end);
        if (end.started)
            message +=
                fmt::format(" (the last good state is step {}, t = {:.17g})", end.steps, double(end.steps) * s.dt());
        if (csv) {
            csv->stream() << "# INCOMPLETE: " << message << "\n";
            csv->commit();
        }
        r["status"] = "step_failed";
        r["failure"] = message;
        r["failed_step"] = end.started ? end.steps + 1 : 0;
        r["residual"] = s.last_residual();
        r["last_correction"] = s.last_correction();
        throw NumericalFailure(message, r);
    }
    if (csv) csv->commit();
    return r;
}

std::string step_text(const json& r) {
    std::string out =
        fmt::format("one step of dt = {} (order {}, method order {}, {} realisation, degree {}):\n",
                    r["dt"].get<double>(), r["order"].get<std::size_t>(), r["method_order"].get<std::size_t>(),
                    r["realisation"].get<std::string>(), r["degree"].get<std::size_t>());
    out += fmt::format("  x = ({:.17g})\n", fmt::join(r["x"].get<std::vector<double>>(), ", "));
    out += fmt::format("  Newton iterations: {}; residual at the solution {:.3g}; last correction {:.3g}\n",
                       r["newton_iterations"].get<int>(), r["residual"].get<double>(), r["correction"].get<double>());
    return out;
}

std::string integrate_text(const json& r) {
    std::string out = fmt::format(
        "integrated {} steps of dt = {} to t = {} (order {}, method order {}, {} realisation, degree {}):\n",
        r["steps"].get<std::size_t>(), r["dt"].get<double>(), r["t"].get<double>(), r["order"].get<std::size_t>(),
        r["method_order"].get<std::size_t>(), r["realisation"].get<std::string>(), r["degree"].get<std::size_t>());
    if (r["t"].get<double>() != r["t_end"].get<double>())
        out += fmt::format("  (t_end = {} is not a whole number of steps: the last step ends at t = {:.17g})\n",
                           r["t_end"].get<double>(), r["t"].get<double>());
    out += fmt::format("  x(t) = ({:.17g})\n", fmt::join(r["x"].get<std::vector<double>>(), ", "));
    out += fmt::format("  max relative energy error: {:.3e}\n", r["energy_error_max"].get<double>());
    const json& errors = r["casimir_error_max"];
    for (std::size_t i = 0; i < errors.size(); ++i)
        out += fmt::format("  max relative error of Casimir {}: {:.3e}\n", casimir_label(r["casimirs"], i),
                           errors[i].get<double>());
    out += fmt::format("  Newton iterations per step: {:.3f}; {:.0f} ns per step; exact phase {:.3f} s\n",
                       r["newton_iterations_mean"].get<double>(), r["ns_per_step"].get<double>(),
                       r["build_seconds"].get<double>());
    return out;
}

}  // namespace pgi
