// pgi section: integrate the scene's run, report the crossings of one event on the dense output.
#include "tools/section.hpp"

#include "poisson/events.hpp"
#include "scheme/run_loop.hpp"
#include "tools/atomic_file.hpp"
#include "tools/commands.hpp"
#include "tools/csv.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <optional>

namespace pgi {

using nlohmann::json;

json section_report(const Scene& scene, const SectionOptions& options) {
    if (!scene.x0) throw SceneError(scene.file, "run.x0", "missing: give [run] x0 or --x0");
    if (!scene.t_end) throw SceneError(scene.file, "run.t_end", "missing: give [run] t_end or --t-end");
    EventSet events = scene.scheme->event_set({{options.event, options.direction, false}}, {});
    // opened before the run, so a bad path is refused before any work; renamed into place only after it
    std::optional<AtomicFile> file;
    if (options.csv) file.emplace(*options.csv);
    const auto start = std::chrono::steady_clock::now();
    Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(scene.x0->data(), Eigen::Index(scene.x0->size()));
    const std::size_t N =
        step_count(scene, options.max_steps, options.samples);  // refused above the budgets, before any work
    NewtonStepper stepper = scene.scheme->stepper(scene.dt, x);
    EventDetector detector(std::move(events), scene.scheme->dense_output(stepper.order()), options.samples);
    json crossings = json::array();
    RunLoop loop(*scene.scheme);  // the run loop of pgi integrate, with the events and no other observer
    const RunEnd run = loop.run(
        stepper, x, N, [](const RunPoint&) { return false; }, &detector,
        [&](const Crossing& c) {
            crossings.push_back({{"t", c.t}, {"x", std::vector<double>(c.x.data(), c.x.data() + c.x.size())}});
            return options.max_crossings && crossings.size() >= *options.max_crossings;
        });
    if (!run.ok()) throw NumericalFailure(loop.failure_message(stepper, run));
    if (file) {
        file->stream() << "t";
        for (const auto& name : scene.phase_space().coordinates()) file->stream() << "," << name;
        file->stream() << "\n";
        for (const auto& c : crossings) {
            file->stream() << csv_number(c["t"].get<double>());
            for (double v : c["x"]) file->stream() << ',' << csv_number(v);
            file->stream() << "\n";
        }
        file->commit();
    }
    return {{"event", options.event},
            {"direction", options.direction},
            {"crossings", crossings},
            {"count", crossings.size()},
            {"steps", run.steps},
            {"t", run.t},
            {"order", scene.order},
            {"method_order", stepper.order()},
            {"dt", scene.dt},
            {"wall_seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}};
}

std::string section_text(const json& r) {
    std::string s = fmt::format("{} crossings of {} = 0 (direction {}) in {} steps to t = {}:\n",
                                r["count"].get<std::size_t>(), r["event"].get<std::string>(), r["direction"].get<int>(),
                                r["steps"].get<std::size_t>(), r["t"].get<double>());
    for (const auto& c : r["crossings"]) {
        s += fmt::format("  t = {:.17g}  x = (", c["t"].get<double>());
        bool first = true;
        for (double v : c["x"]) s += fmt::format("{}{:.17g}", first ? "" : ", ", v), first = false;
        s += ")\n";
    }
    return s;
}

}  // namespace pgi
