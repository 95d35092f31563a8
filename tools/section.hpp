#pragma once
// pgi section: the crossings of an event polynomial along a scene's run (a Poincare section).
#include "tools/commands.hpp"
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace pgi {

struct SectionOptions {
    std::string event;                          // g, in the scene's coordinates
    int direction = 0;                          // +1 rising, -1 falling, 0 both
    std::optional<std::size_t> max_crossings;   // stop after this many
    std::size_t samples = 1;                    // sign tests per step (1: the ends only)
    std::optional<std::filesystem::path> csv;   // t and the coordinates of every crossing
    std::size_t max_steps = default_max_steps;  // --max-steps: the run's step budget
};

/// {"event", "direction", "crossings": [{"t", "x"}], "count", "steps", "t", "order", "method_order",
/// "dt", "wall_seconds"}. Throws ParseError naming a bad event, NumericalFailure on a failed step
/// (no CSV is written then).
nlohmann::json section_report(const Scene& scene, const SectionOptions& options);
std::string section_text(const nlohmann::json& report);

}  // namespace pgi
