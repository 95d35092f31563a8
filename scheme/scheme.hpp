#pragma once
// Scheme: the one owner of a Poisson integrator's exact work (docs/math.md sections 1-7). It holds the
// problem (pi, H, Casimirs, the order k, the realisation choice) and computes each artefact the first
// time it is asked for, once: the checks, the realisation to the p-degree a request needs, S_1..S_k,
// the compiled step for a dt, the modified Hamiltonian to a power of dt. Every user of pgi (the command
// line, the report, the Python module, a C++ program) goes through it.
#include "poisson/dense_output.hpp"
#include "poisson/events.hpp"
#include "poisson/newton_step.hpp"
#include "scheme/input.hpp"
#include "series/compile.hpp"
#include "series/rational.hpp"

#include <Eigen/Dense>

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pgi {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// A run-time constant of a scheme (docs/math.md, "Parameters"): a symbol of the exact phase, an extra coordinate
/// that Poisson-commutes with everything, whose value each run gives (value: the default, exact).
struct Parameter {
    std::string name;
    Rational value;
};

/// Parameter values a run gives by name (the others keep their defaults): one value, or one per trajectory.
using ParameterValues = std::vector<std::pair<std::string, std::vector<double>>>;

/// A scheme from plain values, as a Python caller or a C++ program writes it.
struct SchemeValues {
    std::vector<std::string> coordinates;                       // {"x1", "x2", "x3"}
    std::vector<std::pair<std::string, std::string>> brackets;  // {{"x1,x2", "-x3"}, ...}: {x1, x2} = -x3
    std::string hamiltonian;                                    // "x1^2/2 + x2^2/3 + x3^2/4"
    std::vector<std::string> casimirs;                          // {"x1^2 + x2^2 + x3^2"}
    long order = 2;                                             // k, the Hamilton-Jacobi order
    std::string realisation = "auto";                           // "auto" | "closed-form" | "radial"
    std::size_t max_terms = Ring::default_max_terms;            // bound on every product of the exact phase
    std::size_t max_memory_mb = 0;  // the exact phase's memory (0: default_memory_budget(), series/budget.hpp)
    double max_seconds = BudgetLimits::default_max_seconds;  // its algebra's busy time (none; pgi and Python: 60)
    bool trust_jacobi = false;                               // skip the Jacobi check: the caller vouches for pi
    NativePolicy jit =
        NativePolicy::automatic;  // when the steps' compiled maps become native code (StepOptions::native)
    /// Parameters and their defaults {{"w1", "1/2"}, {"eps", "0.05"}} (exact: 0.05 is 1/20), usable in H and the
    /// Casimirs polynomially, not in the brackets (InputError naming the bracket).
    std::vector<std::pair<std::string, std::string>> parameters;
};

/// The verdicts of the exact checks (docs/math.md sections 1 and 2).
struct SchemeChecks {
    StructureClass structure_class = StructureClass::general;
    bool jacobi_checked = true;                           // false when the scheme trusts pi (trust_jacobi)
    std::optional<JacobiFailure> jacobi;                  // the first failing triple, if any (checked only)
    std::vector<std::optional<CasimirFailure>> casimirs;  // one per listed Casimir
    /// The realisation identities, checked (only when Jacobi holds) in every p-degree below
    /// realisation_checked_below_degree = k: S_1..S_k read alpha through degree k - 1.
    bool realisation_checked = false;
    std::size_t realisation_checked_below_degree = 0;
    std::string realisation_method;
    std::optional<RealisationDefect> realisation;
    bool ok() const;
};

/// How many times each artefact was computed: what the tests read to show that nothing is computed twice.
struct SchemeStats {
    std::size_t realisation_builds = 0, terms_builds = 0, modified_builds = 0, stepper_builds = 0;
    std::size_t evaluator_builds = 0;  // the evaluators' compiled maps (vector_field_map(), ...), each built once
    std::size_t steppers_kept = 0;     // compiled steps in the cache now (at most Scheme::stepper_cache_size)
};

/// The brackets a scheme's pi holds, compiled: output e is {x_i, x_j} for (i, j) = entries[e], i < j; every other
/// entry above the diagonal is zero.
struct CompiledBrackets {
    CompiledMap map;
    std::vector<std::pair<std::size_t, std::size_t>> entries;
};

class Scheme {
public:
    /// Requires casimirs and H in pi's phase space and k >= 1 (InputError otherwise); throws InputError
    /// for closed_form on a general structure. Computes nothing else.
    /// trust_jacobi: the caller vouches for the Jacobi identity of pi, which is then not checked (checks() says
    /// so in jacobi_checked); every other check still runs.
    Scheme(PoissonStructure pi, Poly H, std::vector<Poly> casimirs, std::size_t order,
           RealisationChoice choice = RealisationChoice::automatic, bool trust_jacobi = false,
           NativePolicy jit = NativePolicy::automatic, std::vector<Parameter> parameters = {});
    /// From strings; InputError names the entry at fault ("brackets.\"x1,x2\"", "hamiltonian.H", ...).
    static Scheme from_values(const SchemeValues& values);
    explicit Scheme(const SchemeValues& values) : Scheme(from_values(values)) {}

    /// A copy shares no artefact: it recomputes what it is asked for. It shares the exact phase's budget (its ring's):
    /// the exact work of a scheme and of its copies runs one call at a time, whatever the threads (BudgetSession).
    Scheme(const Scheme& other);
    Scheme& operator=(const Scheme& other);
    Scheme(Scheme&&) noexcept;
    Scheme& operator=(Scheme&&) noexcept;
    ~Scheme();

    // The problem, as given. With parameters, the exact phase space holds the coordinates then the parameters
    // (pi's rows and columns of the parameters are zero): structure(), phase_space(), stepper() and the compiled
    // maps work on the extended state (x, w) of dim() + parameters().size() values; the runs (pgi::integrate,
    // integrate_ensemble, the evaluators) take x and the parameter values apart.
    const PoissonStructure& structure() const { return pi_; }
    const PhaseSpace& phase_space() const { return pi_.phase_space(); }
    const Poly& hamiltonian() const { return H_; }
    const std::vector<Poly>& casimirs() const { return casimirs_; }
    /// The coordinates (the state), without the parameters: n.
    std::size_t dim() const { return pi_.dim() - parameters_.size(); }
    std::vector<std::string> coordinates() const;
    /// The parameters, in their order (the last coordinates of phase_space()), with their defaults.
    const std::vector<Parameter>& parameters() const { return parameters_; }
    /// The values of a run: m rows of one value per parameter, the defaults where values has none. Each entry of
    /// values names a parameter and holds 1 value (every row) or m. InputError("parameters") for an unknown or
    /// repeated name, InputError("parameters.NAME") for a value that is not finite or a length other than 1 or m.
    RowMatrix parameter_rows(const ParameterValues& values, std::size_t m = 1) const;
    /// The extended states (x, w) of the rows of X (m x dim(), unchecked) and of P (1 or m rows of parameter values).
    RowMatrix extended_states(const Eigen::Ref<const RowMatrix>& X, const Eigen::Ref<const RowMatrix>& P) const;
    std::size_t order() const { return k_; }                         // k
    std::size_t method_order() const { return 2 * ((k_ + 1) / 2); }  // 2 ceil(k/2)
    RealisationChoice realisation_choice() const { return choice_; }
    RealisationForm realisation_form() const;
    bool jacobi_trusted() const { return trust_jacobi_; }
    /// When stepper(dt, x_typical)'s compiled maps become native code (StepOptions::native, series/native.hpp).
    NativePolicy jit() const { return jit_; }

    // The artefacts, each computed once, on first use (thread-safe).
    /// Class, Jacobi, the Casimirs and (when Jacobi holds) the realisation identities below degree k.
    const SchemeChecks& checks() const;
    /// Throws InputError naming the triple and jacobiator if Jacobi fails (unless trusted), or the Casimir and
    /// the non-zero component of pi grad C. Checks only Jacobi and the Casimirs (not the realisation).
    void require_valid() const;
    /// alpha and beta through p-degree D: built once at the deepest degree asked so far, truncated for
    /// smaller requests (a deeper request rebuilds).
    Realisation realisation(std::size_t D) const;
    /// S_1..S_k (index 0 holds S_1 = H), docs/math.md section 5.
    const std::vector<Poly>& terms() const;
    /// H_0..H_m of the modified Hamiltonian (docs/math.md section 7), H_0 = H. Kept and returned as a
    /// prefix when less is asked later; extended (recomputed to the new m) when more is.
    std::vector<Poly> modified_hamiltonian(std::size_t m) const;
    /// The compiled step for steps of dt, its realisation degree and predictor chosen at dt and the
    /// typical state x_typical (NewtonStepper::build, from this scheme's realisation and S_1..S_k), returned
    /// as a copy of its own (a stepper holds scratch, so each caller steps its own) whose dt() is dt. A build
    /// serves its own dt and every typical state whose every moving coordinate (PoissonStructure::moving_dimension)
    /// is at most twice its own in magnitude, with each parameter of the same sign and up to twice its magnitude;
    /// another dt, a larger state or value, or another sign builds again. The exact phase (the realisation, S_1..S_k)
    /// is the scheme's, computed once: a build at another dt only sums and compiles S_dt's maps at that dt and chooses
    /// the predictor and the truncations for it, a few milliseconds for the bundled scenes (each dt's step then costs
    /// what it costs at its own dt: a build's run-time dt below its own runs the stacked S_j and Horner, up to twice
    /// the time). At most stepper_cache_size builds are kept (the least recently used is dropped). Throws what
    /// require_valid throws first: S_1..S_k (terms(), modified_hamiltonian(), every stepper) exist only for a valid
    /// scheme. Native code as the scheme's jit policy says (always: NativeCodeError if it cannot be built).
    NewtonStepper stepper(double dt, const Eigen::VectorXd& x_typical) const;
    /// The same with the step's tuning (predictor_order, max_degree, Newton's and the truncation's bounds)
    /// from opt; opt.k and opt.realisation are the scheme's (InputError if they differ), opt.dt is dt.
    NewtonStepper stepper(const StepOptions& opt, const Eigen::VectorXd& x_typical) const;
    static constexpr std::size_t stepper_cache_size = 8;
    /// A run's events (EventSet::build) and the dense output their crossings are located on (DenseOutput::build, for
    /// a step of method_order): each call one exact computation within the scheme's budget, their maps running
    /// machine code as the evaluators' do.
    EventSet event_set(std::vector<EventSpec> specs, const EventNaming& naming) const;
    DenseOutput dense_output(std::size_t method_order) const;
    /// H, the Casimirs, then extra, compiled over the coordinates: what a run watches.
    /// Without extra, a copy of invariants_map().
    CompiledMap invariants(const std::vector<Poly>& extra = {}) const;

    // The numeric evaluators' maps (scheme/evaluators.hpp), over the coordinates, each compiled the first time it is
    // asked for and kept for the scheme's life: the references stay valid. Evaluate them with eval_batch (thread-safe),
    // or eval on a copy (eval's scratch is the map's). Unless jit() is never, eval runs machine code
    // (series/machine_code.hpp), as invariants() does: the interpreter's bits.
    /// pi grad H: output i is dx_i/dt (n outputs).
    const CompiledMap& vector_field_map() const;
    /// The non-zero brackets {x_i, x_j}, i < j.
    const CompiledBrackets& brackets_map() const;
    /// H, then the Casimirs.
    const CompiledMap& invariants_map() const;
    /// H_0..H_upto of the modified Hamiltonian (upto + 1 outputs), one map per upto; throws what
    /// modified_hamiltonian(upto) throws.
    const CompiledMap& modified_hamiltonian_map(std::size_t upto) const;
    SchemeStats stats() const;

private:
    struct Cache;
    const SchemeChecks& structure_checks_locked() const;
    void require_valid_locked() const;
    RealisationPtr realisation_locked(std::size_t D) const;
    const std::vector<Poly>& terms_locked() const;
    CompiledMap compile_invariants(const std::vector<Poly>& extra) const;
    CompiledMap compile_evaluator(const std::vector<Poly>& outputs) const;

    PoissonStructure pi_;
    Poly H_;
    std::vector<Poly> casimirs_;
    std::size_t k_;
    RealisationChoice choice_;
    bool trust_jacobi_ = false;
    NativePolicy jit_ = NativePolicy::automatic;
    std::vector<Parameter> parameters_;
    std::unique_ptr<Cache> cache_;
};

}  // namespace pgi
