// pgi lyapunov: Benettin's exponents along the scene's run, the library's (scheme/lyapunov.cpp), reported.
#include "tools/lyapunov.hpp"

#include "scheme/lyapunov.hpp"
#include "tools/commands.hpp"

#include <fmt/format.h>

#include <chrono>

namespace pgi {

using nlohmann::json;

json lyapunov_report(const Scene& scene, std::size_t every, std::size_t max_steps) {
    if (!scene.x0) throw SceneError(scene.file, "run.x0", "missing: give [run] x0 or --x0");
    if (!scene.t_end) throw SceneError(scene.file, "run.t_end", "missing: give [run] t_end or --t-end");
    const auto start = std::chrono::steady_clock::now();
    // scene.x0 is extended (the coordinates, then the parameters' values): the run takes them apart
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(scene.x0->data(), Eigen::Index(scene.dim()));
    ParameterValues parameters;
    for (std::size_t a = 0; a < scene.parameters.size(); ++a)
        parameters.push_back({scene.parameters[a].name, {scene.parameter_values[a]}});
    RunControl control;
    control.limits.max_steps = max_steps;
    const LyapunovSpectrum l = lyapunov(*scene.scheme, x0, scene.dt, *scene.t_end, every, control, parameters);
    json rows = json::array();
    for (std::size_t r = 0; r < l.t.size(); ++r)
        rows.push_back(
            std::vector<double>(l.exponents.begin() + long(r * l.dim), l.exponents.begin() + long((r + 1) * l.dim)));
    json report = {{"spectrum", l.spectrum},
                   {"leaf_dim", l.leaf_dim},
                   {"t", l.t},
                   {"exponents", rows},
                   {"steps", l.steps},
                   {"t_end", *scene.t_end},
                   {"dt", scene.dt},
                   {"every", every},
                   {"order", scene.order},
                   {"wall_seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}};
    if (l.status != StepStatus::ok) {
        report["status"] = "step_failed";
        report["message"] = l.message;
        throw NumericalFailure(l.message, report);
    }
    return report;
}

std::string lyapunov_text(const json& r) {
    const std::size_t leaf = r["leaf_dim"].get<std::size_t>(), n = r["spectrum"].size();
    std::string s = fmt::format("Lyapunov exponents after {} steps of dt = {} to t = {} (Benettin, QR every step):\n",
                                r["steps"].get<std::size_t>(), r["dt"].get<double>(), r["t_end"].get<double>());
    for (std::size_t i = 0; i < n; ++i)
        s += fmt::format("  lambda_{} = {:+.8f}{}\n", i + 1, r["spectrum"][i].get<double>(),
                         i < leaf ? "" : "  (across the leaf: a Casimir's direction)");
    double sum = 0;
    for (std::size_t i = 0; i < leaf; ++i) sum += r["spectrum"][i].get<double>();
    s += fmt::format("  sum on the leaf: {:.3e}\n", sum);
    return s;
}

}  // namespace pgi
