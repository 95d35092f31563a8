#include "scheme/scheme.hpp"
#include "series/machine_code.hpp"

#include "magnus/modified_hamiltonian.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/detail/truncation_degree.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>

namespace pgi {

bool SchemeChecks::ok() const {
    if (jacobi || realisation) return false;
    return std::none_of(casimirs.begin(), casimirs.end(), [](const auto& c) { return c.has_value(); });
}

namespace detail {  // (named, not anonymous: Scheme::Cache holds them)

// A typical state as a step's build reads it: the magnitudes of its moving coordinates
// (PoissonStructure::moving_dimension), and the values of the coordinates past them (a scheme's parameters).
struct TypicalSize {
    std::vector<double> moving, still;
    TypicalSize(const Eigen::VectorXd& x, std::size_t moving_dimension) {
        const auto m = std::min(x.size(), Eigen::Index(moving_dimension));
        for (Eigen::Index i = 0; i < m; ++i) moving.push_back(std::abs(x[i]));
        still.assign(x.data() + m, x.data() + x.size());
    }
    /// Whether a step built at this typical state serves s: the same magnitude of each moving coordinate, and each
    /// parameter of the same sign and at most twice the magnitude (a build costs 10-80 ms for the rigid body at
    /// k = 4-10, so a sweep of single runs over a parameter must not make one per value; the step sizes the state by
    /// its coordinates). Not coordinates up to twice their size, as before: the build sizes its realisation's
    /// truncation and its predictor at these magnitudes, so a run at x took the step another run had built at a
    /// smaller x0, and its result (whether it succeeded at all) depended on what ran before on the scheme, and on a
    /// pickled copy differed from the original's. Not across a parameter's sign: the predictor's order is chosen
    /// from values, where e x^2 + 5 x^2 at e = -5 cancels.
    bool covers(const TypicalSize& s) const {
        if (s.moving.size() != moving.size() || s.still.size() != still.size()) return false;
        if (s.moving != moving) return false;
        for (std::size_t i = 0; i < still.size(); ++i)
            if (std::signbit(s.still[i]) != std::signbit(still[i]) || !(std::abs(s.still[i]) <= 2 * std::abs(still[i])))
                return false;
        return true;
    }
};

// A compiled step and what it serves: its own dt, the typical states its TypicalSize covers.
struct StepperEntry {
    StepOptions options;
    TypicalSize size;  // of the build's x_typical
    NewtonStepper stepper;
    std::uint64_t used;
    bool serves(const StepOptions& o, const TypicalSize& x_size) const {
        return o.dt == options.dt && size.covers(x_size) && o.predictor_order == options.predictor_order &&
               o.solver == options.solver && o.native == options.native && o.max_degree == options.max_degree &&
               o.newton_max_iter == options.newton_max_iter && o.newton_tol == options.newton_tol &&
               o.truncation_bound == options.truncation_bound;
    }
};

}  // namespace detail

namespace {

using detail::StepperEntry;

// slot's value, built by build() the first time it is asked for (counted in builds).
template <class T, class Build>
const T& built_once(std::optional<T>& slot, std::size_t& builds, Build build) {
    if (!slot) {
        slot.emplace(build());
        ++builds;
    }
    return *slot;
}

// A polynomial's first parameter (a ring variable of index first and up, below the momenta), if it holds one.
std::optional<std::size_t> parameter_in(const Poly& f, std::size_t first, std::size_t end) {
    for (std::size_t v : used_variables(f))
        if (v >= first && v < end) return v;
    return std::nullopt;
}

// InputError unless the parameters are the last coordinates of pi's phase space, named so, with at least one
// coordinate before them, and pi does not hold them: their rows and columns are zero and no entry uses one.
// NOTE: a parameter in a bracket is refused, not supported: the class (constant, linear, log-canonical) and so the
// closed-form realisation are decided on the extended coordinates, where w times a linear bracket is quadratic.
void check_parameters(const PoissonStructure& pi, const std::vector<Parameter>& parameters) {
    const std::size_t q = parameters.size(), N = pi.dim();
    if (q == 0) return;
    if (q >= N) throw InputError("parameters", "a scheme with parameters needs at least one coordinate besides them");
    const auto& names = pi.phase_space().coordinates();
    const std::size_t n = N - q;
    for (std::size_t a = 0; a < q; ++a)
        if (names[n + a] != parameters[a].name)
            throw InputError("parameters." + parameters[a].name, "not the scheme's coordinate " + names[n + a]);
    for (std::size_t i = 0; i < N; ++i)
        for (std::size_t j : pi.row_support(i)) {
            const std::string where = "brackets.\"" + names[i] + "," + names[j] + "\"";
            if (i >= n || j >= n)
                throw InputError(where, "'" + names[std::max(i, j)] +
                                            "' is a parameter: parameters Poisson-commute with everything");
            if (auto v = parameter_in(pi(i, j), n, N))
                throw InputError(where, "uses the parameter '" + names[*v] +
                                            "': parameters are allowed in H and the Casimirs, not in brackets (the "
                                            "structure's class and realisation are decided with them as coordinates)");
        }
}

}  // namespace

// What has been computed so far, read and written under the budget's session (ExactCall).
struct Scheme::Cache {
    explicit Cache(RealisationChoice choice) : realisation(choice) {}
    std::optional<SchemeChecks> checks;
    DeepestRealisation realisation;          // at the deepest p-degree asked so far
    std::optional<std::vector<Poly>> terms;  // S_1..S_k
    std::vector<Poly> modified;              // H_0..H_m for the largest m asked so far
    std::vector<StepperEntry> steppers;      // at most stepper_cache_size
    std::uint64_t clock = 0;                 // the last use of each entry, for eviction
    // the evaluators' maps: node-based, never dropped, so the references handed out stay valid
    std::optional<CompiledMap> vector_field, invariants;
    std::optional<CompiledBrackets> brackets;
    std::map<std::size_t, std::optional<CompiledMap>> modified_maps;  // by upto
    SchemeStats stats;
};

namespace {

// A public call's hold on the scheme's cache, and its exact phase: the session of the ring's budget, which every copy
// of the scheme shares (their exact work runs one call at a time, each with the whole time budget; the time between
// calls, integrating or the caller's own work, a Python session, a Dask worker building steps for one dt after
// another, never counts). Artefacts call each other (the checks ask for the realisation, the modified Hamiltonian for
// S): the session is recursive.
class ExactCall {
public:
    explicit ExactCall(const Scheme& scheme) : session_(scheme.phase_space().ring()->budget()) {}

private:
    BudgetSession session_;
};

}  // namespace

Scheme::Scheme(PoissonStructure pi, Poly H, std::vector<Poly> casimirs, std::size_t order, RealisationChoice choice,
               bool trust_jacobi, NativePolicy jit, std::vector<Parameter> parameters)
    : pi_(std::move(pi)), H_(std::move(H)), casimirs_(std::move(casimirs)), k_(check_order("order", long(order))),
      choice_(choice), trust_jacobi_(trust_jacobi), jit_(jit), parameters_(std::move(parameters)),
      cache_(std::make_unique<Cache>(choice)) {
    check_parameters(pi_, parameters_);
    if (H_.ring() != phase_space().ring())
        throw InputError("hamiltonian.H", "not a polynomial of the scheme's phase space");
    for (std::size_t i = 0; i < casimirs_.size(); ++i)
        if (casimirs_[i].ring() != phase_space().ring())
            throw InputError("hamiltonian.casimirs[" + std::to_string(i) + "]",
                             "not a polynomial of the scheme's phase space");
    try {
        realisation_form();
    } catch (const std::invalid_argument& e) {
        throw InputError("realisation", e.what());
    }
}

Scheme Scheme::from_values(const SchemeValues& v) {
    check_coordinates(v.coordinates);
    std::vector<std::string> names = v.coordinates;
    std::vector<Parameter> parameters;
    for (const auto& [name, value] : v.parameters) {
        parameters.push_back({name, parse_parameter_value("parameters." + name, value)});
        names.push_back(name);
    }
    check_parameter_names(v.coordinates, {names.begin() + long(v.coordinates.size()), names.end()});
    BudgetLimits limits;
    try {  // (budget_limits' own check of the time: one rule, here named as the field)
        limits = budget_limits(v.max_terms, v.max_memory_mb, v.max_seconds);
    } catch (const std::invalid_argument&) {
        throw InputError("max_seconds", "must be positive");
    }
    PhaseSpace M(names, std::make_shared<const Budget>(limits));
    PoissonStructure pi = structure_from_brackets(M, v.brackets);
    Poly H = parse_polynomial(M, "hamiltonian.H", v.hamiltonian);
    std::vector<Poly> casimirs;
    for (std::size_t i = 0; i < v.casimirs.size(); ++i)
        casimirs.push_back(parse_polynomial(M, "hamiltonian.casimirs[" + std::to_string(i) + "]", v.casimirs[i]));
    RealisationChoice choice;
    try {
        choice = parse_realisation_choice(v.realisation);
    } catch (const std::invalid_argument& e) {
        throw InputError("realisation", e.what());
    }
    return Scheme(std::move(pi), std::move(H), std::move(casimirs), check_order("order", v.order), choice,
                  v.trust_jacobi, v.jit, std::move(parameters));
}

Scheme::Scheme(const Scheme& o)
    : pi_(o.pi_), H_(o.H_), casimirs_(o.casimirs_), k_(o.k_), choice_(o.choice_), trust_jacobi_(o.trust_jacobi_),
      jit_(o.jit_), parameters_(o.parameters_), cache_(std::make_unique<Cache>(o.choice_)) {}
Scheme& Scheme::operator=(const Scheme& o) {
    if (this != &o) *this = Scheme(o);
    return *this;
}
Scheme::Scheme(Scheme&&) noexcept = default;
Scheme& Scheme::operator=(Scheme&&) noexcept = default;
Scheme::~Scheme() = default;

std::vector<std::string> Scheme::coordinates() const {
    const auto& all = phase_space().coordinates();
    return {all.begin(), all.begin() + long(dim())};
}

RowMatrix Scheme::parameter_rows(const ParameterValues& values, std::size_t m) const {
    const std::size_t q = parameters_.size();
    RowMatrix P(Eigen::Index(std::max<std::size_t>(m, 1)), Eigen::Index(q));
    for (std::size_t a = 0; a < q; ++a) P.col(Eigen::Index(a)).setConstant(parameters_[a].value.to_double());
    std::vector<bool> given(q, false);
    for (const auto& entry : values) {
        const std::string& name = entry.first;
        const auto& v = entry.second;
        const auto it =
            std::find_if(parameters_.begin(), parameters_.end(), [&](const auto& p) { return p.name == name; });
        if (it == parameters_.end()) {
            std::string known;
            for (const auto& p : parameters_) known += (known.empty() ? "" : ", ") + p.name;
            throw InputError("parameters", "unknown parameter '" + name + "' (the scheme's parameters: " +
                                               (known.empty() ? std::string("none") : known) + ")");
        }
        const auto a = std::size_t(it - parameters_.begin());
        if (given[a]) throw InputError("parameters", "parameter '" + name + "' given twice");
        given[a] = true;
        const std::string key = "parameters." + name;
        if (v.size() != 1 && v.size() != std::size_t(P.rows()))
            throw InputError(key, "has " + std::to_string(v.size()) + " values, for " + std::to_string(P.rows()) +
                                      " trajectories (give 1 value, or one per trajectory)");
        for (std::size_t j = 0; j < v.size(); ++j)
            if (!std::isfinite(v[j])) throw InputError(key, "its value at row " + std::to_string(j) + " is not finite");
        for (Eigen::Index j = 0; j < P.rows(); ++j) P(j, Eigen::Index(a)) = v[v.size() == 1 ? 0 : std::size_t(j)];
    }
    return P;
}

RowMatrix Scheme::extended_states(const Eigen::Ref<const RowMatrix>& X, const Eigen::Ref<const RowMatrix>& P) const {
    const Eigen::Index n = Eigen::Index(dim()), q = Eigen::Index(parameters_.size());
    RowMatrix E(X.rows(), n + q);
    E.leftCols(n) = X;
    for (Eigen::Index j = 0; j < X.rows(); ++j) E.row(j).tail(q) = P.row(P.rows() == 1 ? 0 : j);
    return E;
}

RealisationForm Scheme::realisation_form() const {
    return pgi::realisation_form(pi_.structure_class(), choice_);
}

// Jacobi and the Casimirs first (require_valid needs only these), the realisation identities when checks() asks.
const SchemeChecks& Scheme::structure_checks_locked() const {
    if (!cache_->checks) {
        SchemeChecks c;
        c.structure_class = pi_.structure_class();
        c.jacobi_checked = !trust_jacobi_;
        if (c.jacobi_checked) c.jacobi = pi_.jacobi_failure();
        for (const auto& C : casimirs_) c.casimirs.push_back(pi_.casimir_failure(C));
        cache_->checks = std::move(c);
    }
    return *cache_->checks;
}

const SchemeChecks& Scheme::checks() const {
    const ExactCall call(*this);
    structure_checks_locked();
    SchemeChecks& c = *cache_->checks;
    if (!c.jacobi && !c.realisation_checked) {
        // S_k reads alpha through degree k - 1; the identities in degrees < k need alpha through degree k.
        const RealisationPtr r = realisation_locked(k_);
        c.realisation = realisation_defect(pi_, *r);
        c.realisation_checked_below_degree = r->degree;
        c.realisation_method = r->method;
        c.realisation_checked = true;
    }
    return c;
}

void Scheme::require_valid() const {
    const ExactCall call(*this);
    require_valid_locked();
}

void Scheme::require_valid_locked() const {
    const auto& names = phase_space().coordinates();
    const SchemeChecks& c = structure_checks_locked();
    if (const auto& f = c.jacobi)
        throw InputError("brackets", "the Jacobi identity fails at (" + names[f->i] + ", " + names[f->j] + ", " +
                                         names[f->k] + "): jacobiator = " + f->jacobiator.to_string());
    for (std::size_t i = 0; i < c.casimirs.size(); ++i)
        if (const auto& f = c.casimirs[i])
            throw InputError("hamiltonian.casimirs[" + std::to_string(i) + "]",
                             "'" + casimirs_[i].to_string() + "' is not a Casimir: (pi grad C)_" + names[f->component] +
                                 " = " + f->value.to_string());
}

Realisation Scheme::realisation(std::size_t D) const {
    const ExactCall call(*this);
    return *realisation_locked(D);
}

// A closed form is cheap to build deep: it is built at once to the degree the step's probe reads (its
// predictor's series), so the checks, S and the step share one build.
RealisationPtr Scheme::realisation_locked(std::size_t D) const {
    std::size_t at_least = 0;
    if (realisation_form() != RealisationForm::radial) {
        StepOptions opt;
        opt.k = k_;
        opt.realisation = choice_;
        at_least = probe_degree(realisation_form(), opt, pi_.dim());
    }
    RealisationPtr r = cache_->realisation.through(pi_, D, at_least);
    cache_->stats.realisation_builds = cache_->realisation.builds();
    return r;
}

const std::vector<Poly>& Scheme::terms() const {
    const ExactCall call(*this);
    return terms_locked();
}

const std::vector<Poly>& Scheme::terms_locked() const {
    if (!cache_->terms) {
        require_valid_locked();  // S_1..S_k and everything built on them solve the Hamilton-Jacobi equation of a
                                 // Poisson pi
        // S_1..S_k read alpha only through degree k - 1: a deeper realisation already built serves as is
        const std::size_t D = realisation_degree_for_order(k_);
        if (const RealisationPtr& r = cache_->realisation.deepest(); !r || r->degree < D) realisation_locked(D);
        cache_->terms = hamilton_jacobi_terms(phase_space(), *cache_->realisation.deepest(), H_, k_);
        ++cache_->stats.terms_builds;
    }
    return *cache_->terms;
}

std::vector<Poly> Scheme::modified_hamiltonian(std::size_t m) const {
    const ExactCall call(*this);
    auto& Ht = cache_->modified;
    if (Ht.size() < m + 1) {
        // h through t^m reads beta through p-degree m, S alpha through k - 1: one realisation serves both
        realisation_locked(std::max(m, realisation_degree_for_order(k_)));
        const std::vector<Poly>& S = terms_locked();  // builds the realisation if none was
        Ht = pgi::modified_hamiltonian(pi_, *cache_->realisation.deepest(), S, m);
        ++cache_->stats.modified_builds;
    }
    return {Ht.begin(), Ht.begin() + long(m + 1)};
}

NewtonStepper Scheme::stepper(double dt, const Eigen::VectorXd& x_typical) const {
    StepOptions opt;
    opt.k = k_;
    opt.dt = dt;
    opt.realisation = choice_;
    opt.native = jit_;
    return stepper(opt, x_typical);
}

NewtonStepper Scheme::stepper(const StepOptions& opt, const Eigen::VectorXd& x_typical) const {
    if (opt.k != k_)
        throw InputError("order",
                         "the step's order " + std::to_string(opt.k) + " is not the scheme's " + std::to_string(k_));
    if (opt.realisation != choice_)
        throw InputError("realisation", "the step's realisation choice is not the scheme's");
    if (!(opt.dt > 0) || !std::isfinite(opt.dt))
        throw std::invalid_argument("Scheme::stepper: dt must be positive and finite");
    const detail::TypicalSize size(x_typical, pi_.moving_dimension());
    const ExactCall call(*this);
    auto& cache = cache_->steppers;
    auto best = std::find_if(cache.begin(), cache.end(), [&](const StepperEntry& e) { return e.serves(opt, size); });
    if (best == cache.end()) {
        NewtonStepper built = NewtonStepper::build(
            pi_, terms_locked(), [this](std::size_t D) { return realisation_locked(D); }, opt, x_typical);
        ++cache_->stats.stepper_builds;
        if (cache.size() >= stepper_cache_size)
            cache.erase(std::min_element(cache.begin(), cache.end(),
                                         [](const auto& a, const auto& b) { return a.used < b.used; }));
        cache.push_back({opt, size, std::move(built), 0});
        best = cache.end() - 1;
    }
    best->used = ++cache_->clock;
    best->stepper.adopt_native();  // native code the copies' steps had built, from now on in every copy
    return best->stepper;
}

SchemeStats Scheme::stats() const {
    const ExactCall call(*this);
    SchemeStats s = cache_->stats;
    s.steppers_kept = cache_->steppers.size();
    return s;
}

// outputs compiled over the coordinates, with machine code unless the scheme's jit policy is never (the evaluators and
// a run's invariants: evaluated at every step, they are worth the microseconds it takes).
CompiledMap Scheme::compile_evaluator(const std::vector<Poly>& outputs) const {
    CompiledMap map = CompiledMap::build(outputs, phase_space().coordinate_vars());
    attach_machine_code({&map}, jit_);
    return map;
}

EventSet Scheme::event_set(std::vector<EventSpec> specs, const EventNaming& naming) const {
    const ExactCall call(*this);
    EventSet set = EventSet::build(phase_space(), std::move(specs), naming);
    attach_machine_code(set.compiled_maps(), jit_);
    return set;
}

DenseOutput Scheme::dense_output(std::size_t method_order) const {
    const ExactCall call(*this);
    DenseOutput d = DenseOutput::build(pi_, H_, method_order);
    attach_machine_code(d.compiled_maps(), jit_);
    return d;
}

// H, the Casimirs, then extra, compiled over the coordinates.
CompiledMap Scheme::compile_invariants(const std::vector<Poly>& extra) const {
    std::vector<Poly> f{H_};
    f.insert(f.end(), casimirs_.begin(), casimirs_.end());
    f.insert(f.end(), extra.begin(), extra.end());
    return compile_evaluator(f);
}

CompiledMap Scheme::invariants(const std::vector<Poly>& extra) const {
    return extra.empty() ? invariants_map() : compile_invariants(extra);
}

const CompiledMap& Scheme::invariants_map() const {
    const ExactCall call(*this);
    return built_once(cache_->invariants, cache_->stats.evaluator_builds, [&] { return compile_invariants({}); });
}

const CompiledMap& Scheme::vector_field_map() const {
    const ExactCall call(*this);
    return built_once(cache_->vector_field, cache_->stats.evaluator_builds,
                      [&] { return compile_evaluator(pi_.hamiltonian_vector_field(H_)); });
}

const CompiledBrackets& Scheme::brackets_map() const {
    const ExactCall call(*this);
    return built_once(cache_->brackets, cache_->stats.evaluator_builds, [&] {
        CompiledBrackets b;
        std::vector<Poly> entries;
        for (std::size_t i = 0; i < pi_.dim(); ++i)
            for (std::size_t j : pi_.row_support(i))
                if (j > i) {
                    entries.push_back(pi_(i, j));
                    b.entries.emplace_back(i, j);
                }
        b.map = compile_evaluator(entries);
        return b;
    });
}

const CompiledMap& Scheme::modified_hamiltonian_map(std::size_t upto) const {
    const ExactCall call(*this);
    return built_once(cache_->modified_maps[upto], cache_->stats.evaluator_builds,
                      [&] { return compile_evaluator(modified_hamiltonian(upto)); });
}

}  // namespace pgi
