#pragma once
// Helpers shared by the test suites: building structures from bracket strings and loading bundled scenes.
#include "scheme/scene.hpp"

#include <filesystem>
#include <random>
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

/// Outputs of every kind the interpreter has: empty, constant, short rows, long rows (the four sums and their
/// remainder), and groups of outputs sharing monomials (split into four partial sums with zero padding).
inline std::vector<Poly> mixed_outputs(const RingPtr& r, std::mt19937& gen) {
    std::uniform_int_distribution<long> coeff(-999, 999);
    std::uniform_int_distribution<unsigned long> ex(0, 3);
    const auto random_poly = [&](int terms) {
        Poly f(r);
        for (int t = 0; t < terms; ++t) {
            Poly m = Poly::constant(r, Rational(coeff(gen), static_cast<unsigned long>(1 + std::abs(coeff(gen)))));
            for (std::size_t v = 0; v < 3; ++v) m = m * pow(Poly::gen(r, v + 1), ex(gen));
            f += m;
        }
        return f;
    };
    std::vector<Poly> outputs{Poly(r), Poly::constant(r, Rational(-7, 3))};
    for (int terms : {1, 3, 5, 11, 30}) outputs.push_back(random_poly(terms));
    const Poly shared = random_poly(40);
    for (long c : {2, -3, 5, 7, -11}) outputs.push_back(Poly::constant(r, Rational(c, 8)) * shared + random_poly(2));
    return outputs;
}

/// mixed_outputs in a ring whose variables 4 and 5 are parameters p and q, with coefficients that are polynomials in
/// them: p - 1 vanishes at p = 1, q^2 - p at q^2 = p (compile over {3, 1, 2, 4, 5} with 2 slow inputs).
inline std::vector<Poly> outputs_with_parameters(const RingPtr& r, std::mt19937& gen) {
    const std::vector<Poly> base = mixed_outputs(r, gen);
    const Poly p = Poly::gen(r, 4), q = Poly::gen(r, 5), one = Poly::constant(r, Rational(1));
    std::vector<Poly> outputs;
    for (std::size_t i = 0; i < base.size(); ++i)
        outputs.push_back(base[i] * (i % 2 ? p - one : q * q - p) + base[(i + 3) % base.size()] * q);
    return outputs;
}

}  // namespace pgi::test
