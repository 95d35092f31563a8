#pragma once
// Helpers shared by the test suites: building structures from bracket strings and loading bundled scenes.
#include "scheme/scene.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

namespace pgi::test {

/// Built with a sanitizer (tools/test_sanitized.sh): ten times slower, so the long runs are skipped.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_UNDEFINED__)
constexpr bool sanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(undefined_behavior_sanitizer)
constexpr bool sanitized = true;
#else
constexpr bool sanitized = false;
#endif
#else
constexpr bool sanitized = false;
#endif

/// The whole text of a file (empty if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// pi from {x_i, x_j} strings, the rest zero, its polynomials stored as storage says.
inline PoissonStructure structure(std::vector<std::string> coords,
                                  const std::vector<std::tuple<int, int, std::string>>& brackets,
                                  PolyStorage storage = PolyStorage::automatic) {
    PhaseSpace M(std::move(coords), std::make_shared<const Budget>(BudgetLimits{}), storage);
    std::vector<std::vector<Poly>> pi(M.dim(), std::vector<Poly>(M.dim(), Poly(M.ring())));
    for (const auto& [i, j, s] : brackets) {
        pi[i][j] = M.parse(s);
        pi[j][i] = -pi[i][j];
    }
    return PoissonStructure(M, pi);
}

inline std::string scene_path(const std::string& name) {
    return std::string(PGI_SCENES_DIR) + "/" + name + ".toml";
}
inline Scene bundled(const std::string& name) {
    return load_scene(scene_path(name));
}

inline const std::vector<std::string>& bundled_names() {
    static const std::vector<std::string> names{"rigid_body",     "lotka_volterra",      "harmonic_oscillator",
                                                "henon_heiles",   "plane_quadratic",     "nambu",
                                                "volterra_chain", "kahan_lotka_volterra"};
    return names;
}

/// A plane scheme {x, y} = bracket, H (default the oscillator's), k = 4, stepped through the radial realisation.
inline SchemeValues radial_plane(const std::string& bracket, const std::string& H = "x^2/2 + y^2/2") {
    SchemeValues v;
    v.coordinates = {"x", "y"};
    v.brackets = {{"x,y", bracket}};
    v.hamiltonian = H;
    v.order = 4;
    v.realisation = "radial";
    return v;
}

}  // namespace pgi::test
