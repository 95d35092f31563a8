#pragma once
// pgi lyapunov: the Lyapunov spectrum of a scene's run (scheme/lyapunov.hpp), with its convergence history.
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace pgi {

/// {"spectrum": [n], "leaf_dim", "t": [rows], "exponents": [rows][n], "steps", "t_end", "dt", "every", "order",
/// "wall_seconds"}, from the scene's x0 over its t_end, recorded every `every` steps. Throws SceneError for a missing
/// x0 or t_end, what pgi::lyapunov throws (InputError, RunBudgetError above max_steps), NumericalFailure on a failed
/// step.
nlohmann::json lyapunov_report(const Scene& scene, std::size_t every, std::size_t max_steps);
std::string lyapunov_text(const nlohmann::json& report);

}  // namespace pgi
