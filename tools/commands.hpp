#pragma once
// The pgi commands, each a function from a scene to a JSON document; pgi.cpp renders it as JSON or text.
#include "tools/scene.hpp"

#include <nlohmann/json.hpp>

namespace pgi {

/// Class, skew and Jacobi verdicts, each Casimir's verdict, and the realisation identities through
/// the p-degree the order needs. "ok" is false when any verdict fails.
nlohmann::json check_report(const Scene& scene);
/// S_1..S_k: {"coordinates", "class", "realisation", "S"}.
nlohmann::json terms_report(const Scene& scene);
/// alpha and beta truncated at p-degree D.
nlohmann::json realisation_report(const Scene& scene, std::size_t D);

std::string check_text(const nlohmann::json& report);
std::string terms_text(const nlohmann::json& report);
std::string realisation_text(const nlohmann::json& report);

}  // namespace pgi
