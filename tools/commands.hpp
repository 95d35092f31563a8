#pragma once
// The pgi commands, each a function from a scene to a JSON document; pgi.cpp renders it as JSON or text.
#include "magnus/splitting.hpp"
#include "poisson/newton_step.hpp"
#include "scheme/trajectory.hpp"
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>

namespace pgi {

/// Prints one line of diagnostics ("pgi: ...") on stderr, its control characters shown as \xNN: a path or a name in
/// it may hold any byte (an escape sequence, a newline), and a message stays one line.
void say(const std::string& line);

/// Class, skew and Jacobi verdicts, each Casimir's verdict, and the realisation identities through
/// the p-degree the order needs. "ok" is false when any verdict fails.
nlohmann::json check_report(const Scene& scene);
/// S_1..S_k: {"coordinates", "class", "realisation", "S"}.
nlohmann::json terms_report(const Scene& scene);
/// alpha and beta truncated at p-degree D.
nlohmann::json realisation_report(const Scene& scene, std::size_t D);

/// Thrown when a run stops on a failed step or a non-finite state or invariant (exit code 3): what() says
/// which step, t, the residual and why; partial() is the JSON document of what was computed up to the last
/// good step, with "status": "step_failed" (null when nothing was).
class NumericalFailure : public std::runtime_error {
public:
    explicit NumericalFailure(const std::string& message, nlohmann::json partial = nullptr)
        : std::runtime_error(message), partial_(std::move(partial)) {}
    const nlohmann::json& partial() const { return partial_; }

private:
    nlohmann::json partial_;
};

/// A budget refused the work before it started (exit code 4): the step count above --max-steps, a CSV above
/// --max-csv-mb, kept results above --max-output-mb. The library's refusal (scheme/run_request.hpp), one type.
using BudgetError = RunBudgetError;

/// The default of --max-steps: the library's (RunLimits::default_max_steps).
inline constexpr std::size_t default_max_steps = RunLimits::default_max_steps;

/// The number of steps of a run to the scene's t_end: ceil(t_end / dt) (a t_end that is not a whole
/// number of steps is rounded up, and the run ends at N dt >= t_end), computed in floating point and
/// checked by plan_run. Throws BudgetError above max_steps (or when t_end / dt overflows) or above the limit
/// of event samples, InputError for samples of 0, SceneError without t_end.
std::size_t step_count(const Scene& scene, std::size_t max_steps, std::size_t event_samples = 1);

/// H, the Casimirs, then the extra polynomials, compiled over the coordinates: what runs watch.
CompiledMap invariants(const Scene& scene, const std::vector<Poly>& extra = {});
/// invariant_scales (scheme/trajectory.hpp) for the scene's Scheme at x: what relative_error divides by.
std::vector<double> invariant_scales(const Scene& scene, const std::vector<double>& x,
                                     const std::vector<Poly>& extra = {});
/// The message of a failed step: which step, from which t, why, the iterations, residual and last correction.
std::string failure_message(const NewtonStepper& s, std::size_t step, StepStatus status);

/// Where integrate writes its trajectory (optional) and how it reports progress.
struct IntegrateOptions {
    std::optional<std::filesystem::path> csv;
    std::size_t every = 1;                      // one CSV row every this many steps
    std::size_t max_steps = default_max_steps;  // refuse (before any work) a run of more steps
    double max_csv_mb = 1024;                   // refuse (before running) a CSV that would be larger than this
    bool progress = false;                      // a progress line on stderr for runs longer than a second or two
    std::optional<Poly> modified;               // also track this (a truncated modified Hamiltonian) along the run
    std::vector<double> t_eval;                 // the CSV's rows at these times (partial steps) instead of `every`
    /// Called at every step n (0 = x0) at time t with the state and the watched values (H, the Casimirs,
    /// then the modified Hamiltonian when set): how --plot records a run.
    std::function<void(std::size_t n, double t, const Eigen::VectorXd& x, const std::vector<double>& values)> observe;
};

/// One step from x0: {"x", "newton_iterations", "residual", ...}. Throws NumericalFailure.
nlohmann::json step_report(const Scene& scene);
/// The whole run: {"steps", "t", "x", "energy_error_max", "casimir_error_max", "newton_iterations_mean",
/// "wall_seconds", "energy_warning", ...}; energy_warning (also said on stderr) when the relative energy error
/// exceeds 0.1. Throws NumericalFailure after keeping the CSV written so far, marked incomplete.
nlohmann::json integrate_report(const Scene& scene, const IntegrateOptions& options);

/// M_0..M_m of the Magnus series of the scene's [magnus] h: {"coordinates", "magnus"}.
nlohmann::json magnus_report(const Scene& scene, std::size_t m);
/// H_0..H_m of the modified Hamiltonian of the order-k scheme: {"coordinates", "order", "modified"}.
nlohmann::json modified_report(const Scene& scene, std::size_t m);

/// H_0..H_m of the splitting method for the scene's [splitting] H = A + B (magnus/splitting), with a run of
/// the splitting checking its order of conservation when the flows of A and B are polynomial.
/// Each polynomial of "modified" is written by entry (default: its text), so a report can keep its own form
/// (text and LaTeX) without parsing the text back.
nlohmann::json splitting_report(const Scene& scene, SplittingMethod method, std::size_t m,
                                const std::function<nlohmann::json(const Poly&)>& entry = {});
std::string splitting_text(const nlohmann::json& report);

/// The whole story of a scene: structure and checks, realisation, S_1..S_k, the modified Hamiltonian
/// through dt^m, and (with [run]) a run comparing the conservation of H and of the truncated Htilde.
nlohmann::json report_data(const Scene& scene, std::size_t m);
std::string report_markdown(const nlohmann::json& report);
std::string report_latex(const nlohmann::json& report);

std::string check_text(const nlohmann::json& report);
std::string series_text(const nlohmann::json& report);
std::string integrate_text(const nlohmann::json& report);
std::string step_text(const nlohmann::json& report);
std::string terms_text(const nlohmann::json& report);
std::string realisation_text(const nlohmann::json& report);

}  // namespace pgi
