#pragma once
// The realisation the step evaluates (docs/math.md 3, 4 and 6): a closed form where there is one, otherwise
// the series truncated at the p-degree D whose neglected terms are below round-off at the typical state.
#include "poisson/realisation_eval.hpp"
#include "poisson/step_options.hpp"

#include <Eigen/Dense>

namespace pgi {

/// The lowest p-degree the step reads: S_1..S_k need k - 1 (docs/math.md 5), and at least 1.
std::size_t step_degree_min(std::size_t k);
/// The degree the step's build first asks its source for (the probe): for the radial recursion two degrees
/// past step_degree_min to fit the decay (deepened only where D needs it: the exact recursion is the costly
/// part); for a closed form on fewer than shallow_probe_from coordinates, enough for the predictor's longest
/// series (predictor_limit), built at once; from there on (lattices: every degree holds O(n) terms of O(n)
/// words each) enough for its first pass (predictor_first_pass), deepened only if its choice goes on; two
/// more for the constant form (whose D is measured).
std::size_t probe_degree(RealisationForm form, const StepOptions& opt, std::size_t n);
inline constexpr std::size_t shallow_probe_from = 40;

/// The evaluator of alpha and beta - alpha, and what was chosen.
struct StepRealisation {
    RealisationEvaluator evaluator;
    std::string method;
    std::size_t degree = 0;          // D (0 for the log-canonical closed form)
    bool exact = false;              // a closed form: no truncation
    double truncation_estimate = 0;  // the largest neglected |A_m| / |x| at the typical state
    /// Whether the acceptance test's alpha (RealisationEvaluator::check) is computed by the same formula as
    /// Newton's (eval), so that simplified Newton on it converges to Newton's root: every form but the
    /// general Lie-Poisson one, whose check sums g(L) x otherwise than eval does (differing by ~1e-13 |x|
    /// past the series' radius).
    bool simplified_newton = true;
};

/// Where the build sizes a truncated realisation: the typical state's magnitudes, and the momenta's there.
struct SizePoint {
    Eigen::VectorXd x;  // |x_typical|, each coordinate (a scheme's parameters too)
    Eigen::VectorXd p;  // the sizes of grad S_dt's terms at x (its gradient_size map at the build's dt)
};

/// A closed form where there is one (log-canonical; so(3)*-type; any other Lie-Poisson structure by its
/// series to the degree whose tail is below round-off at p0 = grad S_dt(x_typical), scaling and squaring beyond),
/// otherwise the compiled series truncated at the smallest D whose neglected terms are below round-off (capped at
/// opt.max_degree), measured as the sizes of their terms at `sizes` (term_size): a bound at every state of at most
/// those magnitudes, whatever their signs, where values at the typical state cancel ((x + y)^2 at (1, -1),
/// a x^2 - b x^2 at a = b) and a run ended "ok" off, or a build reused at another state failed on its truncation.
/// (A coordinate at 0 bounds only states where it is 0: Scheme's stepper cache serves per coordinate.) probe: the realisation at probe_degree,
/// deepened in place from source when D needs it, "below round-off" relative to scale (the size of x_typical's
/// moving coordinates).
StepRealisation step_realisation(const PoissonStructure& pi, const StepOptions& opt, RealisationPtr& probe,
                                 const RealisationSource& source, double scale, const Eigen::VectorXd& p0,
                                 const SizePoint& sizes);

}  // namespace pgi
