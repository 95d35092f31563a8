#pragma once
// Scene: a TOML file read into exact objects (the only place that knows TOML).
#include "scheme/scheme.hpp"
#include "series/message.hpp"

#include <memory>

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pgi {

/// Bad input: what() reads "FILE: key: problem", control characters escaped.
class SceneError : public std::runtime_error {
public:
    SceneError(const std::filesystem::path& file, const std::string& key, const std::string& problem)
        : std::runtime_error(printable(file.string() + ": " + (key.empty() ? "" : key + ": ") + problem)) {}
};

/// Scene files larger than this are refused before they are read (the largest bundled scene is 1 kB; a
/// 1000-coordinate lattice is about 40 kB).
inline constexpr std::size_t max_scene_bytes = 8u << 20;

/// Command-line values that replace the scene's, in the scene's own forms ("1/10", "0.6,0.8,0.3").
struct SceneOverrides {
    std::optional<std::string> order, dt, realisation, x0, t_end;
    std::vector<std::string> parameters;                     // --param NAME=VALUE: a parameter's value for the run
    std::size_t max_terms = Ring::default_max_terms;         // --max-terms: the exact phase's product bound
    std::size_t max_memory_mb = 0;                           // --max-memory-mb: its memory (0: default_memory_budget())
    double max_seconds = BudgetLimits::default_max_seconds;  // --max-seconds: its algebra's time (none; pgi: 60)
    Budget::ProgressSink progress;                           // progress lines of a long exact phase
    bool trust_jacobi = false;                               // --trust-jacobi: the Jacobi identity is not checked
    std::optional<NativePolicy> jit;  // --jit (always) or --no-jit (never): when the step's maps become native code
};

struct Scene {
    std::filesystem::path file;
    std::string name;
    /// [parameters]: the last coordinates of pi's phase space, Poisson-commuting with everything (Scheme::parameters).
    std::vector<Parameter> parameters;
    PoissonStructure pi;
    Poly H;
    std::vector<Poly> casimirs;
    std::size_t order = 2;  // k
    double dt = 0.1;
    std::string dt_text = "1/10";  // as written, for reports
    RealisationChoice realisation = RealisationChoice::automatic;
    /// [integrator] jit: true always, false never, absent automatic (when the step's maps become native code).
    NativePolicy jit = NativePolicy::automatic;
    /// The parameters' values of the run: the defaults, or --param's.
    std::vector<double> parameter_values;
    /// The initial state, extended: the coordinates, then parameter_values (what the scheme's stepper steps).
    std::optional<std::vector<double>> x0;
    std::optional<double> t_end;
    std::optional<Series> magnus_h;   // [magnus] h, a t-series
    std::optional<Poly> splitting_A;  // [splitting] A: H = A + B, B = H - A, for splitting methods
    /// The exact work on pi, H, the Casimirs, order and realisation above (checks, realisation, S_1..S_k,
    /// the step, the modified Hamiltonian), each computed once when a command first asks for it.
    std::shared_ptr<const Scheme> scheme;

    const PhaseSpace& phase_space() const { return pi.phase_space(); }
    /// The coordinates, without the parameters (x0's length).
    std::size_t dim() const { return pi.dim() - parameters.size(); }
};

/// Reads and checks a scene. Throws SceneError for anything malformed: syntax, missing keys, wrong
/// types, polynomials that do not parse, brackets that are not skew or contradict each other,
/// order < 1, dt <= 0, non-finite numbers, x0 of the wrong length. Does not check Jacobi or the
/// Casimirs: require_valid() does, check_report() reports them.
Scene load_scene(const std::filesystem::path& file, const SceneOverrides& overrides = {});
/// The same from the text of a scene; file only names it in messages.
Scene parse_scene(std::string_view text, const std::filesystem::path& file, const SceneOverrides& overrides = {});

/// Throws SceneError naming the triple and the jacobiator if pi fails Jacobi, or the Casimir and
/// the non-zero component of pi grad C if a listed Casimir is not one.
void require_valid(const Scene& scene);

}  // namespace pgi
