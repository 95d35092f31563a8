#include "tools/ensemble.hpp"

#include "scheme/ensemble.hpp"
#include "scheme/trajectory.hpp"
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"
#include "tools/csv.hpp"
#include "tools/npy.hpp"
#include "tools/sample.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <iostream>
#include <map>
#include <memory>

namespace pgi {

void add_ensemble_options(CLI::App* cmd, EnsembleCommandOptions& o) {
    auto* states = cmd->add_option("--states", o.states,
                                   "initial states, one per row: an NPY file (float64, (m, n)) or a CSV file");
    auto* sample =
        cmd->add_option("--sample", o.sample, "grid | box | casimir: seeded initial states instead of --states")
            ->check(CLI::IsMember({"grid", "box", "casimir"}));
    states->excludes(sample);
    cmd->add_option("--count", o.count, "how many states to sample (grid: g^n)")
        ->needs(sample)
        ->check(CLI::PositiveNumber);
    cmd->add_option("--seed", o.seed, "the sampler's seed (default 0)")->needs(sample);
    cmd->add_option("--box", o.box, "lo,hi or lo1,hi1,...,lon,hin: the sampler's box")->needs(sample);
    cmd->add_option("--threads", o.threads, "worker threads (default: every core)")->check(CLI::PositiveNumber);
    cmd->add_option("--chunk", o.chunk, "trajectories per task (default: about 8 tasks per thread)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--batch", o.batch,
                    "trajectories stepped together (default 16 below 40 coordinates, else 1: one at a time)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--params", o.params,
                    "the scene's parameter values, one row per state, one column per parameter in the scene's order "
                    "(NPY or CSV; default: the defaults or --param, for every state)");
    cmd->add_option("--out", o.out, "write PREFIX.x0.npy, PREFIX.x.npy, PREFIX.errors.npy and PREFIX.csv")->required();
}

namespace {

std::string names(const std::vector<std::string>& coordinates, const std::string& prefix = "",
                  const std::string& suffix = "") {
    std::string s;
    for (const auto& c : coordinates) s += (s.empty() ? "" : ",") + prefix + c + suffix;
    return s;
}
std::string names(const Scene& scene, const std::string& prefix = "", const std::string& suffix = "") {
    return names(scene.scheme->coordinates(), prefix, suffix);
}

// The rows of an NPY or CSV file of the given columns (named by header), m of them.
RowMatrix read_rows(const std::string& file, const char* option, std::size_t columns, const std::string& header,
                    const EnsembleCommandOptions& o) {
    const std::filesystem::path p(file);
    const auto max_bytes = std::size_t(o.limits.max_output_mb * double(1 << 20));
    RowMatrix X = p.extension() == ".npy" ? read_npy(p, max_bytes)
                  : p.extension() == ".csv"
                      ? read_csv_states(p, columns, header, max_bytes)
                      : throw InputError(file, std::string(option) + " must be a .npy or .csv file");
    if (std::size_t(X.cols()) != columns)
        throw InputError(file, "holds " + std::to_string(X.cols()) + " columns, " + option + " needs " +
                                   std::to_string(columns) + " (" + header + ")");
    if (X.rows() == 0) throw InputError(file, "holds no rows: nothing to integrate");
    return X;
}

// The parameters' values of the m trajectories: --params's columns, else the scene's values (defaults, --param).
ParameterValues parameter_values(const Scene& scene, const EnsembleCommandOptions& o, Eigen::Index m) {
    ParameterValues w;
    std::vector<std::string> parameter_names;
    for (const auto& p : scene.parameters) parameter_names.push_back(p.name);
    if (o.params.empty()) {
        for (std::size_t a = 0; a < scene.parameters.size(); ++a)
            w.push_back({scene.parameters[a].name, {scene.parameter_values[a]}});
        return w;
    }
    if (scene.parameters.empty()) throw InputError("--params", "the scene has no [parameters]");
    const RowMatrix P = read_rows(o.params, "--params", scene.parameters.size(), names(parameter_names), o);
    if (P.rows() != m)
        throw InputError(
            o.params, "holds " + std::to_string(P.rows()) + " rows of parameters for " + std::to_string(m) + " states");
    for (std::size_t a = 0; a < scene.parameters.size(); ++a) {
        const Eigen::VectorXd column = P.col(Eigen::Index(a));
        w.push_back({scene.parameters[a].name, {column.data(), column.data() + column.size()}});
    }
    return w;
}

RowMatrix initial_states(const Scene& scene, const EnsembleCommandOptions& o) {
    const std::size_t n = scene.dim();
    if (o.states.empty() && o.sample.empty())
        throw InputError("ensemble", "give the initial states: --states FILE or --sample KIND");
    if (!o.states.empty()) {
        if (o.x0_given) throw InputError("--x0", "is read only by --sample casimir (the level set through x0)");
        const std::filesystem::path p(o.states);
        const auto max_bytes = std::size_t(o.limits.max_output_mb * double(1 << 20));
        RowMatrix X = p.extension() == ".npy"   ? read_npy(p, max_bytes)
                      : p.extension() == ".csv" ? read_csv_states(p, n, names(scene), max_bytes)
                                                : throw InputError(o.states, "--states must be a .npy or .csv file");
        if (std::size_t(X.cols()) != n)
            throw InputError(o.states, "holds " + std::to_string(X.cols()) + " columns, the scene has " +
                                           std::to_string(n) + " coordinates (" + names(scene) + ")");
        if (X.rows() == 0) throw InputError(o.states, "holds no states (no rows): nothing to integrate");
        return X;
    }
    if (!scene.parameters.empty())
        throw InputError("--sample", "not supported for a scene with [parameters] yet: give --states");
    SampleSpec spec;
    spec.kind = parse_sample_kind(o.sample);
    spec.count = o.count;
    if (!spec.count) throw InputError("--count", "missing: --sample needs --count N");
    spec.seed = o.seed;
    if (o.box.empty()) throw InputError("--box", "missing: --sample needs --box lo,hi");
    parse_box(o.box, n, spec);
    if (scene.x0) spec.through = Eigen::Map<const Eigen::VectorXd>(scene.x0->data(), Eigen::Index(n));
    return sample_states(*scene.scheme, spec);
}

std::string status_line(const EnsembleResult& r, std::size_t i) {
    const auto& e = r.members[i];
    if (e.status == TrajectoryStatus::non_finite_start)
        return fmt::format("row {}: non_finite_start (the initial state is not finite)", i);
    return fmt::format("row {}: {} at step {} (from t = {}), residual {:.3g}", i, to_string(e.status), e.failed_step,
                       e.failed_t, e.residual);
}

void write_csv(std::ostream& out, const Scene& scene, const RowMatrix& X0, const EnsembleResult& r) {
    out << "index,status,steps,failed_step,failed_t,residual,newton_iterations_mean,newton_iterations_max,energy_error,"
           "energy_warning";
    for (std::size_t c = 0; c < scene.casimirs.size(); ++c) out << ",casimir_error_" << c + 1;
    out << "," << names(scene, "", "_0") << "," << names(scene) << "\n";
    for (std::size_t i = 0; i < r.members.size(); ++i) {
        const auto& e = r.members[i];
        const auto row = Eigen::Index(i);
        out << fmt::format("{},{},{},{},{},{},{},{},{},{}", i, to_string(e.status), e.steps, e.failed_step,
                           csv_number(e.failed_t), csv_number(e.residual), csv_number(e.newton_iterations_mean),
                           e.newton_iterations_max, csv_number(r.energy_error(row)), int(e.energy_warning));
        for (Eigen::Index c = 0; c < r.casimir_error.cols(); ++c) out << ',' << csv_number(r.casimir_error(row, c));
        for (Eigen::Index c = 0; c < X0.cols(); ++c) out << ',' << csv_number(X0(row, c));
        for (Eigen::Index c = 0; c < X0.cols(); ++c) out << ',' << csv_number(r.x(row, c));
        out << "\n";
    }
}

nlohmann::json summary(const Scene& scene, const EnsembleResult& r, const EnsembleCommandOptions& o, double dt,
                       double t_end, double seconds, const std::vector<std::string>& files) {
    std::map<std::string, std::size_t> counts;
    double energy = 0, casimir = 0;
    std::size_t steps = 0, warnings = 0;
    for (std::size_t i = 0; i < r.members.size(); ++i) {
        ++counts[to_string(r.members[i].status)];
        steps += r.members[i].steps;
        warnings += r.members[i].energy_warning;
        if (r.members[i].status != TrajectoryStatus::ok) continue;
        energy = std::max(energy, r.energy_error(Eigen::Index(i)));
        if (r.casimir_error.cols()) casimir = std::max(casimir, r.casimir_error.row(Eigen::Index(i)).maxCoeff());
    }
    nlohmann::json j{{"scene", scene.file.string()},
                     {"trajectories", r.members.size()},
                     {"status", counts},
                     {"threads", r.threads},
                     {"dt", dt},
                     {"t_end", t_end},
                     {"steps", std::size_t(steps_to_reach(t_end, dt))},
                     {"order", scene.order},
                     {"method_order", scene.scheme->method_order()},
                     {"energy_error_max", energy},
                     {"casimir_error_max", casimir},
                     {"energy_warnings", warnings},
                     {"wall_seconds", seconds},
                     {"steps_per_second", seconds > 0 ? double(steps) / seconds : 0.0},
                     {"files", files}};
    j["x_typical"] = std::vector<double>(r.x_typical.data(), r.x_typical.data() + r.x_typical.size());
    if (!o.sample.empty()) j["sample"] = {{"kind", o.sample}, {"count", o.count}, {"seed", o.seed}, {"box", o.box}};
    return j;
}

std::string summary_text(const nlohmann::json& j) {
    std::string s = fmt::format(
        "ensemble of {} trajectories x {} steps of dt = {} to t = {} (order {}, method order {}), {} threads:\n",
        j["trajectories"].get<std::size_t>(), j["steps"].get<std::size_t>(), j["dt"].get<double>(),
        j["t_end"].get<double>(), j["order"].get<std::size_t>(), j["method_order"].get<std::size_t>(),
        j["threads"].get<std::size_t>());
    for (const auto& [status, count] : j["status"].items())
        s += fmt::format("  {}: {}\n", status, count.get<std::size_t>());
    s += fmt::format("  max relative energy error (ok trajectories): {:.3e}\n  max relative Casimir error: {:.3e}\n",
                     j["energy_error_max"].get<double>(), j["casimir_error_max"].get<double>());
    s += fmt::format("  {:.3g} s, {:.3g} steps per second\n", j["wall_seconds"].get<double>(),
                     j["steps_per_second"].get<double>());
    for (const auto& f : j["files"]) s += "  wrote " + f.get<std::string>() + "\n";
    return s;
}

// The run's size, checked before any work: its steps and, when sampled, its count (a file's rows are checked
// by integrate_ensemble once read; the file's size is bounded as it is read).
void check_size(const Scene& scene, const EnsembleCommandOptions& o) {
    const std::size_t m = o.sample.empty() ? 1 : o.count;
    try {
        plan_ensemble(*scene.scheme, m, scene.dt, *scene.t_end, o.limits);
    } catch (const RunBudgetError& e) {
        throw RunBudgetError(scene.file.string() + ": " + e.what() + (o.sample.empty() ? "" : " (--count)"));
    }
}

}  // namespace

int ensemble_command(const Scene& scene, const EnsembleCommandOptions& o, bool json) {
    if (!scene.t_end) throw InputError("--t-end", "missing: give --t-end or [run] t_end");
    check_size(scene, o);
    // every output opened before any work, none of them an input (the scene, the states): a bad directory is
    // refused here, and nothing is half-written
    std::vector<std::filesystem::path> inputs{scene.file};
    if (!o.states.empty()) inputs.emplace_back(o.states);
    if (!o.params.empty()) inputs.emplace_back(o.params);
    const std::vector<std::string> files{o.out + ".x0.npy", o.out + ".x.npy", o.out + ".errors.npy", o.out + ".csv"};
    std::vector<std::unique_ptr<AtomicFile>> out;
    for (const auto& f : files) out.push_back(std::make_unique<AtomicFile>(f, inputs));
    const RowMatrix X0 = initial_states(scene, o);
    require_valid(scene);
    EnsembleOptions options;
    options.threads = o.threads;
    options.chunk = o.chunk;
    options.batch = o.batch;
    options.control.limits = o.limits;
    options.parameters = parameter_values(scene, o, X0.rows());
    const auto start = std::chrono::steady_clock::now();
    const EnsembleResult r = integrate_ensemble(*scene.scheme, X0, scene.dt, *scene.t_end, options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    RowMatrix errors(X0.rows(), 1 + r.casimir_error.cols());
    errors << r.energy_error, r.casimir_error;
    write_npy(out[0]->stream(), X0);
    write_npy(out[1]->stream(), r.x);
    write_npy(out[2]->stream(), errors);
    write_csv(out[3]->stream(), scene, X0, r);
    commit_all(out);
    const auto j = summary(scene, r, o, scene.dt, *scene.t_end, seconds, files);
    std::cout << (json ? j.dump(2) + "\n" : summary_text(j)) << std::flush;
    // NOTE: as `pgi integrate` says of one run (tools/run.cpp), never silently: exit 0 with H off by a tenth or more
    if (const std::size_t w = j["energy_warnings"]; w > 0)
        say(fmt::format(
            "pgi: {}: warning: {} of {} trajectories reached a relative energy error above {} (energy_warning in "
            "{}): every step solved its equation, but at dt = {} order {} does not follow the flow of H there "
            "(reduce dt or raise the order)",
            scene.file.string(), w, r.members.size(), energy_warning_from, files[3], scene.dt, scene.order));
    std::size_t failed = 0, first = 0;
    for (std::size_t i = r.members.size(); i-- > 0;)
        if (r.members[i].status != TrajectoryStatus::ok) ++failed, first = i;
    if (!failed) return 0;
    say("pgi: " + scene.file.string() + ": " + std::to_string(failed) + " of " + std::to_string(r.members.size()) +
        " trajectories did not reach t_end (see " + files[3] + "); first: " + status_line(r, first));
    return 3;
}

}  // namespace pgi
