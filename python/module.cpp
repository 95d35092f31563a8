// pgi._pgi: the Scheme for Python (pybind11). The pure-Python package pgi/__init__.py wraps it: the arguments'
// types and ranges checked, results as objects, StepFailure raised from a failed step's report, sympy conversions.
// Every failure here becomes a Python exception: the library's InputError, ResourceLimitError (a run above its
// budget: RunBudgetError), NativeCodeError; std::bad_alloc a MemoryError; Ctrl-C a KeyboardInterrupt (interruptible).
#include "poisson/step_jacobian.hpp"
#include "scheme/ensemble.hpp"
#include "scheme/evaluators.hpp"
#include "scheme/lyapunov.hpp"
#include "scheme/run_request.hpp"
#include "scheme/scheme.hpp"
#include "scheme/trajectory.hpp"
#include "scheme/version.hpp"
#include "series/latex.hpp"
#include "scheme/scene.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <exception>
#include <future>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <thread>
#include <tuple>
#include <type_traits>

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

// Runs work(cancel) (C++ only: it must not touch a Python object) on a thread of its own while the calling
// thread, the GIL released, waits for it in slices of 30 ms and between them checks for signals with the GIL
// held (PyErr_CheckSignals runs Python's handlers: Ctrl-C raises KeyboardInterrupt). On a signal the run's
// flag is set, the worker stops at its next step (RunInterrupted, discarded) and the handler's exception is
// raised; otherwise the worker's result is returned or its exception rethrown here. Every long call of the
// module goes through it: integrate, integrate_ensemble, a step's build and the exact phase (which does not
// poll the flag: a signal during it is raised when it ends).
template <class Work>
auto interruptible(Work work) -> decltype(work(std::declval<const pgi::RunCancel&>())) {
    using Result = decltype(work(std::declval<const pgi::RunCancel&>()));
    using Slot = std::conditional_t<std::is_void_v<Result>, bool, std::optional<Result>>;
    pgi::RunCancel cancel;
    Slot result{};
    std::exception_ptr error;
    bool signalled = false;
    {
        py::gil_scoped_release release;
        std::promise<void> done;
        std::future<void> finished = done.get_future();
        std::thread worker([&] {
            try {
                if constexpr (std::is_void_v<Result>) {
                    work(cancel);
                    result = true;
                } else {
                    result.emplace(work(cancel));
                }
            } catch (...) {
                error = std::current_exception();
            }
            done.set_value();
        });
        while (finished.wait_for(std::chrono::milliseconds(30)) != std::future_status::ready) {
            py::gil_scoped_acquire acquire;
            if (PyErr_CheckSignals() != 0) {  // the handler raised: its exception is pending on this thread
                cancel.cancel();
                signalled = true;
                break;
            }
        }
        worker.join();
    }
    if (signalled) throw py::error_already_set();
    if (error) std::rethrow_exception(error);
    if constexpr (!std::is_void_v<Result>) return std::move(*result);
}

// The budgets a caller gave (None: the library's defaults), checked by the library's plan_run.
pgi::RunLimits limits(std::optional<std::size_t> max_steps, std::optional<double> max_output_mb) {
    pgi::RunLimits l;
    if (max_steps) l.max_steps = *max_steps;
    if (max_output_mb) l.max_output_mb = *max_output_mb;
    return l;
}

// A scheme with the run parameters a scene (or the caller) gave, and one stepper per dt for step().
struct PyScheme {
    std::shared_ptr<const pgi::Scheme> scheme;
    std::optional<double> dt, t_end;
    std::optional<Eigen::VectorXd> x0;
    std::string name;
    std::map<double, pgi::NewtonStepper> steppers;  // step(): built at x0, or at the first x stepped with that dt

    const pgi::PhaseSpace& M() const { return scheme->phase_space(); }

    Eigen::VectorXd state(const Eigen::VectorXd& x, const char* what) const {
        if (static_cast<std::size_t>(x.size()) != scheme->dim())
            throw pgi::InputError(
                what, "must have " + std::to_string(scheme->dim()) + " values, got " + std::to_string(x.size()));
        if (!x.allFinite()) throw pgi::InputError(what, "must be finite");
        return x;
    }
    double step_size(std::optional<double> given) const {
        std::optional<double> h = given ? given : dt;
        if (!h) throw pgi::InputError("dt", "missing: give dt (the scheme has none)");
        if (!(*h > 0) || !std::isfinite(*h)) throw pgi::InputError("dt", "must be positive and finite");
        return *h;
    }
    // The extended state (x, w) of x with the parameter values w (the defaults where none is given).
    Eigen::VectorXd extended(const Eigen::VectorXd& x, const pgi::ParameterValues& w) const {
        return scheme->extended_states(x.transpose(), scheme->parameter_rows(w)).row(0).transpose();
    }
};

std::vector<std::string> texts(const std::vector<pgi::Poly>& v, bool latex) {
    std::vector<std::string> out;
    for (const auto& p : v) out.push_back(latex ? pgi::to_latex(p) : p.to_string());
    return out;
}

// Python's jit: None (automatic), True (always) or False (never), as the scene's integrator.jit.
pgi::NativePolicy native_policy(std::optional<bool> jit) {
    if (!jit) return pgi::NativePolicy::automatic;
    return *jit ? pgi::NativePolicy::always : pgi::NativePolicy::never;
}

std::optional<bool> jit_of(pgi::NativePolicy p) {
    if (p == pgi::NativePolicy::automatic) return std::nullopt;
    return p == pgi::NativePolicy::always;
}

PyScheme from_values(std::vector<std::string> coordinates, const py::dict& brackets, std::string hamiltonian,
                     std::vector<std::string> casimirs, long order, std::string realisation, std::optional<double> dt,
                     std::optional<Eigen::VectorXd> x0, std::optional<double> t_end, std::size_t max_terms,
                     bool trust_jacobi, std::optional<bool> jit,
                     std::vector<std::pair<std::string, std::string>> parameters, std::optional<double> max_seconds,
                     std::size_t max_memory_mb) {
    pgi::SchemeValues v;
    v.max_seconds = max_seconds.value_or(pgi::BudgetLimits::default_max_seconds);
    v.max_memory_mb = max_memory_mb;
    v.parameters = std::move(parameters);
    v.trust_jacobi = trust_jacobi;
    v.jit = native_policy(jit);
    v.coordinates = std::move(coordinates);
    for (auto [k, value] : brackets) {
        if (!py::isinstance<py::str>(k) || !py::isinstance<py::str>(value))
            throw pgi::InputError("brackets", "keys and values must be strings, like {\"x1,x2\": \"-x3\"}");
        v.brackets.emplace_back(k.cast<std::string>(), value.cast<std::string>());
    }
    v.hamiltonian = std::move(hamiltonian);
    v.casimirs = std::move(casimirs);
    v.order = order;
    v.realisation = std::move(realisation);
    v.max_terms = max_terms;
    PyScheme s;
    {
        py::gil_scoped_release release;
        s.scheme = std::make_shared<const pgi::Scheme>(pgi::Scheme::from_values(v));
    }
    s.dt = dt;
    s.t_end = t_end;
    if (x0) s.x0 = s.state(*x0, "x0");
    if (dt) s.step_size(dt);
    if (t_end && (!(*t_end >= 0) || !std::isfinite(*t_end)))
        throw pgi::InputError("t_end", "must be finite and not negative");
    return s;
}

PyScheme from_scene(const pgi::Scene& scene) {
    PyScheme s;
    s.scheme = scene.scheme;
    s.name = scene.name;
    s.dt = scene.dt;
    s.t_end = scene.t_end;
    if (scene.x0) s.x0 = Eigen::Map<const Eigen::VectorXd>(scene.x0->data(), Eigen::Index(scene.dim()));  // no w
    return s;
}

// trust_jacobi, jit and the exact phase's budget as the command line's --trust-jacobi, --jit / --no-jit (None: as the
// scene says), --max-seconds (None: no limit), --max-memory-mb (0: the default) and --max-terms.
pgi::SceneOverrides overrides(bool trust_jacobi, std::optional<bool> jit, std::optional<double> max_seconds,
                              std::size_t max_memory_mb, std::size_t max_terms) {
    pgi::SceneOverrides o;
    o.max_terms = max_terms;
    o.trust_jacobi = trust_jacobi;
    if (jit) o.jit = native_policy(jit);
    o.max_seconds = max_seconds.value_or(pgi::BudgetLimits::default_max_seconds);
    o.max_memory_mb = max_memory_mb;
    return o;
}

PyScheme from_toml(const std::string& path, bool trust_jacobi, std::optional<bool> jit,
                   std::optional<double> max_seconds, std::size_t max_memory_mb, std::size_t max_terms) {
    py::gil_scoped_release release;
    return from_scene(pgi::load_scene(path, overrides(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms)));
}

// The scene's text (what a pickled Scheme carries to another process); file only names it in messages.
PyScheme from_toml_text(const std::string& text, const std::string& file, bool trust_jacobi, std::optional<bool> jit,
                        std::optional<double> max_seconds, std::size_t max_memory_mb, std::size_t max_terms) {
    py::gil_scoped_release release;
    return from_scene(
        pgi::parse_scene(text, file, overrides(trust_jacobi, jit, max_seconds, max_memory_mb, max_terms)));
}

py::dict check(const PyScheme& s) {
    const auto& scheme = *s.scheme;
    const pgi::SchemeChecks& c = *interruptible([&](const pgi::RunCancel&) { return &scheme.checks(); });
    const auto& names = s.M().coordinates();
    // as the command line's JSON: {"holds": true}, the failing triple, or not checked (trust_jacobi)
    py::dict jacobi("holds"_a = !c.jacobi);
    if (!c.jacobi_checked) jacobi = py::dict("holds"_a = py::none(), "skipped"_a = "trust_jacobi");
    if (c.jacobi)
        jacobi = py::dict("holds"_a = false,
                          "triple"_a = py::make_tuple(names[c.jacobi->i], names[c.jacobi->j], names[c.jacobi->k]),
                          "jacobiator"_a = c.jacobi->jacobiator.to_string());
    py::list casimirs;
    for (std::size_t i = 0; i < c.casimirs.size(); ++i) {
        py::dict d("C"_a = s.scheme->casimirs()[i].to_string(), "holds"_a = !c.casimirs[i]);
        if (const auto& f = c.casimirs[i]) {
            d["component"] = names[f->component];
            d["value"] = f->value.to_string();
        }
        casimirs.append(d);
    }
    py::dict r("class"_a = pgi::to_string(c.structure_class), "jacobi"_a = jacobi, "casimirs"_a = casimirs);
    if (c.realisation_checked) {
        py::dict id("method"_a = c.realisation_method, "checked_below_degree"_a = c.realisation_checked_below_degree,
                    "holds"_a = !c.realisation);
        if (const auto& d = c.realisation)
            id["failure"] = py::dict("identity"_a = d->identity, "i"_a = names[d->i], "j"_a = names[d->j],
                                     "degree"_a = d->degree, "defect"_a = d->defect.to_string());
        r["realisation"] = id;
    }
    r["ok"] = c.ok();
    return r;
}

// The compiled step of dt that step() and step_jacobian() take: built at x0, or at the first x stepped with that dt.
pgi::NewtonStepper& cached_stepper(PyScheme& s, const Eigen::VectorXd& x, double dt) {
    if (std::size_t(x.size()) != s.M().dim())  // a caller that does not extend x yet
        throw pgi::InputError("parameters", "not supported here yet: the scheme has parameters");
    auto it = s.steppers.find(dt);
    if (it == s.steppers.end()) {
        const Eigen::VectorXd typical = s.x0 ? s.extended(*s.x0, {}) : x;
        // the exact phase (require_valid first); the map is touched only with the GIL held
        const auto& scheme = *s.scheme;
        pgi::NewtonStepper built = interruptible([&](const pgi::RunCancel&) { return scheme.stepper(dt, typical); });
        it = s.steppers.emplace(dt, std::move(built)).first;
    }
    return it->second;
}

// A failed step's report, for the Python side to raise StepFailure.
void report_failure(py::dict& r, const pgi::NewtonStepper& st, pgi::StepStatus status) {
    const auto why = status == pgi::StepStatus::ok ? pgi::StepStatus::non_finite : status;
    r["ok"] = false;
    r["message"] = pgi::step_failure_message(st, 1, why);
    r["residual"] = st.last_residual();
}

// One step with its Jacobian (poisson/step_jacobian.hpp): the new state and d x_new / d x, or the failure's
// report. On the extended state (x, w) at the parameters' values: the coordinates' block (w's rows are those of I).
py::dict step_jacobian(PyScheme& s, const Eigen::VectorXd& x_in, std::optional<double> dt_in,
                       const pgi::ParameterValues& parameters) {
    const Eigen::VectorXd x = s.extended(s.state(x_in, "x"), parameters);
    const double dt = s.step_size(dt_in);
    pgi::NewtonStepper& st = cached_stepper(s, x, dt);
    const pgi::StepWithJacobian j = pgi::step_with_jacobian(st, x, dt);
    const auto n = Eigen::Index(s.scheme->dim());
    py::dict r("newton_iterations"_a = st.last_iterations(), "status"_a = pgi::to_string(j.status));
    if (j.status == pgi::StepStatus::ok && j.x_new.allFinite()) {
        r["x"] = Eigen::VectorXd(j.x_new.head(n));
        r["jacobian"] = Eigen::MatrixXd(j.jacobian.topLeftCorner(n, n));
        r["ok"] = true;
    } else {
        report_failure(r, st, j.status);
    }
    return r;
}

// One step: the new state, or the failure's report for the Python side to raise StepFailure. The step runs on the
// extended state (x, w) (w's increments are exactly 0).
py::dict step(PyScheme& s, const Eigen::VectorXd& x_in, std::optional<double> dt_in,
              const pgi::ParameterValues& parameters) {
    const Eigen::VectorXd x = s.extended(s.state(x_in, "x"), parameters);
    const double dt = s.step_size(dt_in);
    pgi::NewtonStepper& st = cached_stepper(s, x, dt);
    Eigen::VectorXd increment(x.size());
    const pgi::StepStatus status = st.step(x, increment);
    Eigen::VectorXd next = (x + increment).head(Eigen::Index(s.scheme->dim()));
    py::dict r("newton_iterations"_a = st.last_iterations(), "status"_a = pgi::to_string(status));
    if (status == pgi::StepStatus::ok && next.allFinite()) {
        r["x"] = next;
        r["ok"] = true;
    } else {
        report_failure(r, st, status);
    }
    return r;
}

double run_length(const PyScheme& s, std::optional<double> t_end_in) {
    std::optional<double> t_end = t_end_in ? t_end_in : s.t_end;
    if (!t_end) throw pgi::InputError("t_end", "missing: give t_end (the scheme has none)");
    if (!(*t_end >= 0) || !std::isfinite(*t_end)) throw pgi::InputError("t_end", "must be finite and not negative");
    return *t_end;
}

// The events as pgi/__init__.py normalises them: (g, direction, terminal). A bad one is an InputError
// naming it as Python does ("events[1]: malformed polynomial 'q + w': unknown variable 'w' at position 4").
pgi::TrajectoryEvents trajectory_events(const std::vector<std::tuple<std::string, int, bool>>& events,
                                        std::size_t samples) {
    if (samples < 1) throw pgi::InputError("event_samples", "must be at least 1");
    pgi::TrajectoryEvents e;
    for (const auto& [g, direction, terminal] : events) e.specs.push_back({g, direction, terminal});
    e.samples = samples;
    e.naming = {"events[", 0, "]"};
    return e;
}

// Where and why a run that ended early stopped (a Trajectory or a LyapunovSpectrum): nothing for one that did not.
template <class Run>
void add_failure(py::dict& r, const Run& run) {
    if (run.status == pgi::StepStatus::ok) return;
    r["failed_step"] = run.failed_step;
    r["failed_t"] = run.failed_t;
    r["residual"] = run.failed_residual;
    r["message"] = run.message;
}

py::dict crossings(const pgi::Trajectory& tr) {
    const auto k = static_cast<py::ssize_t>(tr.crossings.size()), n = static_cast<py::ssize_t>(tr.dim);
    py::array_t<std::int64_t> index(k), step(k);  // numpy's own index type (np.bincount, fancy indexing)
    py::array_t<double> t(k), x({k, n});
    for (py::ssize_t i = 0; i < k; ++i) {
        const pgi::Crossing& c = tr.crossings[std::size_t(i)];
        index.mutable_at(i) = std::int64_t(c.event);
        step.mutable_at(i) = std::int64_t(c.step);
        t.mutable_at(i) = c.t;
        std::copy(c.x.data(), c.x.data() + n, x.mutable_data(i, 0));
    }
    return py::dict("event_index"_a = index, "event_t"_a = t, "event_x"_a = x, "event_step"_a = step);
}

py::dict integrate(const PyScheme& s, std::optional<Eigen::VectorXd> x0_in, std::optional<double> dt_in,
                   std::optional<double> t_end_in, std::size_t every, std::optional<Eigen::VectorXd> x_typical,
                   const std::vector<std::tuple<std::string, int, bool>>& events, std::size_t event_samples,
                   std::optional<std::size_t> max_steps, std::optional<double> max_output_mb, bool tangent,
                   const pgi::ParameterValues& parameters, std::optional<std::vector<double>> t_eval) {
    if (!x0_in && !s.x0) throw pgi::InputError("x0", "missing: give x0 (the scheme has none)");
    const Eigen::VectorXd x0 = s.state(x0_in ? *x0_in : *s.x0, "x0");
    const double dt = s.step_size(dt_in);
    const double t_end = run_length(s, t_end_in);
    if (every < 1) throw pgi::InputError("every", "must be at least 1");
    if (x_typical) s.state(*x_typical, "x_typical");
    const pgi::TrajectoryEvents watched = trajectory_events(events, event_samples);
    pgi::RunControl control;
    control.limits = limits(max_steps, max_output_mb);
    pgi::Trajectory tr;
    try {
        // the exact phase (first call) and the run: C++ only, on a worker, stopped by Ctrl-C
        const auto& scheme = *s.scheme;
        tr = interruptible([&](const pgi::RunCancel& cancel) {
            pgi::RunControl c = control;
            c.cancel = &cancel;
            return pgi::integrate(scheme, x0, dt, t_end, every, x_typical, watched, c, parameters, tangent,
                                  t_eval ? std::span<const double>(*t_eval) : std::span<const double>());
        });
    } catch (const pgi::ParseError& e) {  // a bad event (the other arguments were checked above)
        throw pgi::InputError("", e.what());
    } catch (const pgi::InputError&) {
        throw;
    } catch (const std::invalid_argument& e) {
        throw pgi::InputError("", e.what());
    }
    const auto rows = static_cast<py::ssize_t>(tr.t.size()), n = static_cast<py::ssize_t>(tr.dim);
    const auto C = static_cast<py::ssize_t>(tr.casimir_error_max.size());
    py::array_t<double> x({rows, n}), cas({rows, C});
    std::copy(tr.x.begin(), tr.x.end(), x.mutable_data());
    std::copy(tr.casimir_error.begin(), tr.casimir_error.end(), cas.mutable_data());
    py::dict r(
        "t"_a = py::array_t<double>(rows, tr.t.data()), "x"_a = x,
        "energy_error"_a = py::array_t<double>(rows, tr.energy_error.data()), "casimir_error"_a = cas,
        "energy_error_max"_a = tr.energy_error_max, "casimir_error_max"_a = tr.casimir_error_max,
        "casimir_drift_per_step"_a = tr.casimir_drift_per_step, "energy_warning"_a = tr.energy_warning,
        "steps"_a = tr.steps, "dt"_a = dt, "newton_iterations_mean"_a = tr.newton_iterations_mean,
        "newton_iterations_max"_a = tr.newton_iterations_max,
        // the ensemble's vocabulary (status_of), so a member's status is its single run's, word for word
        "status"_a = tr.terminal_event ? std::string("terminal_event") : pgi::to_string(pgi::status_of(tr.status)));
    r.attr("update")(crossings(tr));  // empty without events
    if (tangent) {
        py::array_t<double> jacobian({n, n});
        std::copy(tr.jacobian.begin(), tr.jacobian.end(), jacobian.mutable_data());
        r["jacobian"] = jacobian;
    }
    add_failure(r, tr);
    return r;
}

// The Lyapunov spectrum (scheme/lyapunov.hpp): the running estimates' history, the spectrum, the failure's report.
py::dict lyapunov(const PyScheme& s, std::optional<Eigen::VectorXd> x0_in, std::optional<double> dt_in,
                  std::optional<double> t_end_in, std::size_t every, std::optional<std::size_t> max_steps,
                  std::optional<double> max_output_mb, const pgi::ParameterValues& parameters) {
    if (!x0_in && !s.x0) throw pgi::InputError("x0", "missing: give x0 (the scheme has none)");
    const Eigen::VectorXd x0 = s.state(x0_in ? *x0_in : *s.x0, "x0");
    const double dt = s.step_size(dt_in);
    const double t_end = run_length(s, t_end_in);
    pgi::RunControl control;
    control.limits = limits(max_steps, max_output_mb);
    const auto& scheme = *s.scheme;
    const pgi::LyapunovSpectrum l = interruptible([&](const pgi::RunCancel& cancel) {
        pgi::RunControl c = control;
        c.cancel = &cancel;
        return pgi::lyapunov(scheme, x0, dt, t_end, every, c, parameters);
    });
    const auto rows = static_cast<py::ssize_t>(l.t.size()), n = static_cast<py::ssize_t>(l.dim);
    py::array_t<double> exponents({rows, n});
    std::copy(l.exponents.begin(), l.exponents.end(), exponents.mutable_data());
    py::dict r("t"_a = py::array_t<double>(rows, l.t.data()), "exponents"_a = exponents,
               "spectrum"_a = py::array_t<double>(py::ssize_t(l.spectrum.size()), l.spectrum.data()),
               "leaf_dim"_a = l.leaf_dim, "steps"_a = l.steps, "dt"_a = dt,
               "status"_a = pgi::to_string(pgi::status_of(l.status)));
    add_failure(r, l);
    return r;
}

// An array's shape as text: "(4, 2)", "(3,)".
std::string shape_of(const py::array& a) {
    std::string shape = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(a.shape(d));
    return shape + (a.ndim() == 1 ? ",)" : ")");
}

// X0 as the ensemble reads it (and the evaluators their x, named so): a 2-D float64 numpy array with one column
// per coordinate, checked before any work and not copied yet.
py::array ensemble_states(const PyScheme& s, const py::object& X0, const std::string& name = "X0") {
    if (!py::isinstance<py::array>(X0)) throw pgi::InputError(name, "must be a numpy array of shape (m, n), float64");
    const auto a = py::reinterpret_borrow<py::array>(X0);
    const std::size_t n = s.scheme->dim();
    if (!py::array_t<double>::check_(a))  // dtype equivalent to float64 (native byte order)
        throw pgi::InputError(name, "must have dtype float64, got " + py::str(a.dtype()).cast<std::string>());
    if (a.ndim() != 2 || std::size_t(a.shape(1)) != n)
        throw pgi::InputError(
            name, "must have shape (m, " + std::to_string(n) + "), one column per coordinate, got " + shape_of(a));
    return a;
}

// a as a C-contiguous float64 array: itself, or a copy. ensure() returns a null array (its error cleared) when
// the copy fails: raised as MemoryError naming the argument (name) and the size, never used.
py::array_t<double, py::array::c_style> contiguous(const py::array& a, const std::string& name = "X0") {
    auto c = py::array_t<double, py::array::c_style>::ensure(a);
    if (!c) {
        const double mb = double(a.size()) * 8.0 / double(1 << 20);
        PyErr_SetString(PyExc_MemoryError, (name + ": out of memory for a C-contiguous copy of shape " + shape_of(a) +
                                            " (about " + std::to_string(long(mb)) + " MB); pass fewer rows at a time")
                                               .c_str());
        throw py::error_already_set();
    }
    return c;
}

// What an ensemble of m trajectories keeps, checked as integrate_ensemble checks it (plan_run: the steps of one
// trajectory, the results of all), here before X0 is copied: InputError or ResourceLimitError (RunBudgetError).
Eigen::Map<const pgi::RowMatrix> as_matrix(const py::array_t<double, py::array::c_style>& a) {
    return {a.data(), Eigen::Index(a.shape(0)), Eigen::Index(a.shape(1))};
}

// What each trajectory of an ensemble records (pgi::TrajectoryOptions), as integrate_ensemble's arguments give it.
struct Recording {
    std::size_t every = 0;
    std::optional<std::vector<double>> t_eval;
    std::vector<std::tuple<std::string, int, bool>> events;
    std::size_t event_samples = 1;
    bool tangent = false;

    pgi::TrajectoryOptions options() const {
        pgi::TrajectoryOptions o;
        o.every = every;
        if (t_eval) o.t_eval = *t_eval;
        o.events = trajectory_events(events, event_samples);
        o.tangent = tangent;
        return o;
    }
};

// A recording ensemble's per-trajectory arrays: rows (x (m, records, n), t, rows), crossings, tangent maps.
void add_records(py::dict& d, const pgi::EnsembleResult& r, const pgi::TrajectoryOptions& record, py::ssize_t n) {
    const auto m = static_cast<py::ssize_t>(r.members.size());
    if (record.every > 0 || !record.t_eval.empty()) {
        const auto k = static_cast<py::ssize_t>(r.record_t.size());
        py::array_t<double> x({m, k, n});
        std::copy(r.record_x.begin(), r.record_x.end(), x.mutable_data());
        py::array_t<std::int64_t> rows(m);
        for (py::ssize_t i = 0; i < m; ++i) rows.mutable_at(i) = std::int64_t(r.members[std::size_t(i)].rows);
        d["x"] = x;
        d["t"] = py::array_t<double>(k, r.record_t.data());
        d["rows"] = rows;
    }
    if (!record.events.specs.empty()) {
        const auto c = static_cast<py::ssize_t>(r.crossings.size());
        py::array_t<std::int64_t> row(c), index(c), step(c);
        py::array_t<double> t(c), x({c, n});
        for (py::ssize_t j = 0; j < c; ++j) {
            const pgi::EnsembleCrossing& e = r.crossings[std::size_t(j)];
            row.mutable_at(j) = std::int64_t(e.row);
            index.mutable_at(j) = std::int64_t(e.crossing.event);
            step.mutable_at(j) = std::int64_t(e.crossing.step);
            t.mutable_at(j) = e.crossing.t;
            std::copy(e.crossing.x.data(), e.crossing.x.data() + n, x.mutable_data(j, 0));
        }
        py::array_t<bool> terminal(m);
        for (py::ssize_t i = 0; i < m; ++i) terminal.mutable_at(i) = r.members[std::size_t(i)].terminal_event;
        d["event_row"] = row, d["event_index"] = index, d["event_t"] = t, d["event_x"] = x, d["event_step"] = step;
        d["terminal_event"] = terminal;
    }
    if (record.tangent) {
        py::array_t<double> jacobian({m, n, n});
        std::copy(r.jacobian.begin(), r.jacobian.end(), jacobian.mutable_data());
        d["jacobian"] = jacobian;
    }
}

py::dict integrate_ensemble(const PyScheme& s, const py::object& X0_in, std::optional<double> dt_in,
                            std::optional<double> t_end_in, std::size_t threads, std::size_t chunk,
                            std::optional<Eigen::VectorXd> x_typical, std::size_t batch,
                            std::optional<std::size_t> max_steps, std::optional<double> max_output_mb,
                            const pgi::ParameterValues& parameters, const Recording& recording) {
    const py::array states = ensemble_states(s, X0_in);
    const double dt = s.step_size(dt_in);
    const double t_end = run_length(s, t_end_in);
    if (x_typical) s.state(*x_typical, "x_typical");
    pgi::EnsembleOptions options;
    options.threads = threads;
    options.chunk = chunk;
    options.batch = batch;
    options.x_typical = x_typical;
    options.control.limits = limits(max_steps, max_output_mb);
    options.parameters = parameters;
    options.record = recording.options();
    s.scheme->parameter_rows(parameters, std::size_t(states.shape(0)));  // their checks, before the copy
    pgi::plan_ensemble(*s.scheme, std::size_t(states.shape(0)), dt, t_end, options.control.limits,
                       options.record);  // before the copy
    const auto X0 = contiguous(states);
    // X0 stays alive (held here) and is only read; the run is C++ only, on a worker, stopped by Ctrl-C
    const auto& scheme = *s.scheme;
    const Eigen::Map<const pgi::RowMatrix> rows = as_matrix(X0);
    pgi::EnsembleResult r;
    try {
        r = interruptible([&](const pgi::RunCancel& cancel) {
            pgi::EnsembleOptions o = options;
            o.control.cancel = &cancel;
            return pgi::integrate_ensemble(scheme, rows, dt, t_end, o);
        });
    } catch (const pgi::ParseError& e) {  // a bad event (the other arguments were checked above)
        throw pgi::InputError("", e.what());
    }
    const auto m = static_cast<py::ssize_t>(r.members.size());
    py::list status;
    py::array_t<std::size_t> steps(m), failed_step(m);
    py::array_t<double> failed_t(m), residual(m), newton_mean(m);
    py::array_t<int> newton_max(m);
    py::array_t<bool> energy_warning(m);
    for (py::ssize_t i = 0; i < m; ++i) {
        const auto& e = r.members[std::size_t(i)];
        status.append(e.terminal_event ? std::string("terminal_event") : pgi::to_string(e.status));
        steps.mutable_at(i) = e.steps;
        failed_step.mutable_at(i) = e.failed_step;
        failed_t.mutable_at(i) = e.failed_t;
        residual.mutable_at(i) = e.residual;
        newton_mean.mutable_at(i) = e.newton_iterations_mean;
        newton_max.mutable_at(i) = e.newton_iterations_max;
        energy_warning.mutable_at(i) = e.energy_warning;
    }
    py::object x_typ = r.x_typical.size() ? py::cast(r.x_typical) : py::none();
    py::object x = py::cast(r.x);  // (its own array: a caller writing into x leaves x_final as the run left it)
    py::object x_final = py::cast(std::move(r.x));
    py::dict d("x"_a = x, "x_final"_a = x_final, "energy_error"_a = py::cast(std::move(r.energy_error)),
               "casimir_error"_a = py::cast(std::move(r.casimir_error)), "status"_a = status, "steps"_a = steps,
               "failed_step"_a = failed_step, "failed_t"_a = failed_t, "residual"_a = residual,
               "newton_iterations_mean"_a = newton_mean, "newton_iterations_max"_a = newton_max,
               "energy_warning"_a = energy_warning, "x_typical"_a = x_typ, "threads"_a = r.threads, "dt"_a = dt,
               "t_end"_a = t_end);
    add_records(d, r, options.record, py::ssize_t(scheme.dim()));
    return d;
}

// f(scheme, X) at the rows X of x (an (m, n) float64 array; InputError naming x), returned as numpy, with the GIL
// released: interruptible (on a thread of its own) when f may run the exact phase, else on this thread (cheap
// enough for an ODE solver's every call).
template <class F>
py::object evaluate(const PyScheme& s, const py::object& x, bool exact_phase, F f) {
    const auto rows = contiguous(ensemble_states(s, x, "x"), "x");
    const Eigen::Map<const pgi::RowMatrix> X = as_matrix(rows);
    const pgi::Scheme& scheme = *s.scheme;
    if (exact_phase) return py::cast(interruptible([&](const pgi::RunCancel&) { return f(scheme, X); }));
    auto values = [&] {
        py::gil_scoped_release release;
        return f(scheme, X);
    }();
    return py::cast(std::move(values));
}

// The method of Scheme evaluating f, which runs no exact phase, at the rows of x with the parameter values w.
template <class Values>
auto at_rows(Values (*f)(const pgi::Scheme&, const Eigen::Ref<const pgi::RowMatrix>&, const pgi::ParameterValues&)) {
    return [f](const PyScheme& s, const py::object& x, const pgi::ParameterValues& w) {
        return evaluate(s, x, false, [&](const pgi::Scheme& scheme, const auto& X) { return f(scheme, X, w); });
    };
}

py::dict stats(const PyScheme& s) {
    const pgi::SchemeStats st = s.scheme->stats();
    return py::dict("realisation_builds"_a = st.realisation_builds, "terms_builds"_a = st.terms_builds,
                    "modified_builds"_a = st.modified_builds, "stepper_builds"_a = st.stepper_builds,
                    "steppers_kept"_a = st.steppers_kept, "evaluator_builds"_a = st.evaluator_builds);
}

}  // namespace

PYBIND11_MODULE(_pgi, m) {
    m.doc() = "pgi's C++ core; use the package pgi";
    m.attr("__version__") = std::string(pgi::version());
    m.attr("max_scene_bytes") = pgi::max_scene_bytes;
    // Bad input is a ValueError (InputError carries the entry at fault in its message); a budget (of the exact
    // phase, or a run's: RunBudgetError) a RuntimeError of its own. A failed step is reported, and
    // pgi/__init__.py raises StepFailure. Out of memory is a MemoryError saying so; a run stopped without a
    // signal pending (RunInterrupted) a KeyboardInterrupt. Translators registered later are tried first.
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const std::bad_alloc&) {
            PyErr_SetString(PyExc_MemoryError,
                            "out of memory (std::bad_alloc): what this call keeps did not fit; record less "
                            "(a larger every=), pass fewer rows at a time or lower max_output_mb");
        } catch (const pgi::RunInterrupted&) {
            PyErr_SetString(PyExc_KeyboardInterrupt, "the run was interrupted");
        }
    });
    auto& input_error = py::register_exception<pgi::InputError>(m, "InputError", PyExc_ValueError);
    py::register_exception<pgi::SceneError>(m, "SceneError", input_error.ptr());
    py::register_exception<pgi::ResourceLimitError>(m, "ResourceLimitError", PyExc_RuntimeError);
    py::register_exception<pgi::NativeCodeError>(m, "NativeCodeError", PyExc_RuntimeError);

    // The checked entry points: pgi/__init__.py checks types and ranges first and documents them.
    py::class_<Recording>(m, "_Recording")  // what an ensemble's trajectories record (pgi/__init__.py checks it)
        .def(py::init([](std::size_t every, std::optional<std::vector<double>> t_eval,
                         std::vector<std::tuple<std::string, int, bool>> events, std::size_t event_samples,
                         bool tangent) {
                 return Recording{every, std::move(t_eval), std::move(events), event_samples, tangent};
             }),
             "every"_a = 0, "t_eval"_a = py::none(), "events"_a = std::vector<std::tuple<std::string, int, bool>>{},
             "event_samples"_a = 1, "tangent"_a = false);
    py::class_<PyScheme>(m, "Scheme")
        .def(py::init(&from_values), "coordinates"_a, "brackets"_a, "hamiltonian"_a,
             "casimirs"_a = std::vector<std::string>{}, "order"_a = 2, "realisation"_a = "auto", "dt"_a = py::none(),
             "x0"_a = py::none(), "t_end"_a = py::none(), "max_terms"_a = pgi::Ring::default_max_terms,
             "trust_jacobi"_a = false, "jit"_a = py::none(),
             "parameters"_a = std::vector<std::pair<std::string, std::string>>{}, "max_seconds"_a = py::none(),
             "max_memory_mb"_a = 0)
        .def_static("from_toml", &from_toml, "path"_a, "trust_jacobi"_a = false, "jit"_a = py::none(),
                    "max_seconds"_a = py::none(), "max_memory_mb"_a = 0, "max_terms"_a = pgi::Ring::default_max_terms)
        .def_static("from_toml_text", &from_toml_text, "text"_a, "file"_a, "trust_jacobi"_a = false,
                    "jit"_a = py::none(), "max_seconds"_a = py::none(), "max_memory_mb"_a = 0,
                    "max_terms"_a = pgi::Ring::default_max_terms)
        .def_property_readonly("jacobi_trusted", [](const PyScheme& s) { return s.scheme->jacobi_trusted(); })
        .def_property_readonly("jit", [](const PyScheme& s) { return jit_of(s.scheme->jit()); })
        .def_property_readonly("name", [](const PyScheme& s) { return s.name; })
        .def_property_readonly("coordinates", [](const PyScheme& s) { return s.scheme->coordinates(); })
        .def_property_readonly("parameters",
                               [](const PyScheme& s) {
                                   std::vector<std::pair<std::string, std::string>> p;
                                   for (const auto& w : s.scheme->parameters())
                                       p.emplace_back(w.name, w.value.to_string());
                                   return p;
                               })
        .def_property_readonly("order", [](const PyScheme& s) { return s.scheme->order(); })
        .def_property_readonly("method_order", [](const PyScheme& s) { return s.scheme->method_order(); })
        .def_property_readonly("realisation",
                               [](const PyScheme& s) { return pgi::to_string(s.scheme->realisation_form()); })
        .def_property_readonly(
            "structure_class",
            [](const PyScheme& s) { return pgi::to_string(s.scheme->structure().structure_class()); })
        .def_property_readonly("hamiltonian", [](const PyScheme& s) { return s.scheme->hamiltonian().to_string(); })
        .def_property_readonly("casimirs", [](const PyScheme& s) { return texts(s.scheme->casimirs(), false); })
        .def_property_readonly("dt", [](const PyScheme& s) { return s.dt; })
        .def_property_readonly("x0", [](const PyScheme& s) { return s.x0; })
        .def_property_readonly("t_end", [](const PyScheme& s) { return s.t_end; })
        .def("check", &check)
        .def("require_valid",
             [](const PyScheme& s) {
                 const auto& scheme = *s.scheme;
                 interruptible([&](const pgi::RunCancel&) { scheme.require_valid(); });
             })
        .def(
            "terms",
            [](const PyScheme& s, bool latex) {
                const auto& scheme = *s.scheme;
                return interruptible([&](const pgi::RunCancel&) { return texts(scheme.terms(), latex); });
            },
            "latex"_a = false)
        .def(
            "modified_hamiltonian",
            [](const PyScheme& s, std::size_t upto, bool latex) {
                const auto& scheme = *s.scheme;
                return interruptible(
                    [&](const pgi::RunCancel&) { return texts(scheme.modified_hamiltonian(upto), latex); });
            },
            "upto"_a = 4, "latex"_a = false)
        .def(
            "realisation_terms",
            [](const PyScheme& s, std::size_t degree) {
                const auto& scheme = *s.scheme;
                pgi::Realisation r = interruptible([&](const pgi::RunCancel&) { return scheme.realisation(degree); });
                std::vector<std::string> alpha, beta;
                for (const auto& a : r.alpha) alpha.push_back(a.sum().to_string());
                for (const auto& b : r.beta) beta.push_back(b.sum().to_string());
                return py::dict("method"_a = r.method, "degree"_a = r.degree, "alpha"_a = alpha, "beta"_a = beta);
            },
            "degree"_a)
        .def("_step", &step, "x"_a, "dt"_a = py::none(), "parameters"_a = pgi::ParameterValues{})
        .def("_step_jacobian", &step_jacobian, "x"_a, "dt"_a = py::none(), "parameters"_a = pgi::ParameterValues{})
        .def("_integrate", &integrate, "x0"_a = py::none(), "dt"_a = py::none(), "t_end"_a = py::none(), "every"_a = 1,
             "x_typical"_a = py::none(), "events"_a = std::vector<std::tuple<std::string, int, bool>>{},
             "event_samples"_a = 1, "max_steps"_a = py::none(), "max_output_mb"_a = py::none(), "tangent"_a = false,
             "parameters"_a = pgi::ParameterValues{}, "t_eval"_a = py::none())
        .def("_lyapunov", &lyapunov, "x0"_a = py::none(), "dt"_a = py::none(), "t_end"_a = py::none(), "every"_a = 1,
             "max_steps"_a = py::none(), "max_output_mb"_a = py::none(), "parameters"_a = pgi::ParameterValues{})
        .def("_integrate_ensemble", &integrate_ensemble, "X0"_a, "dt"_a = py::none(), "t_end"_a = py::none(),
             "threads"_a = 0, "chunk"_a = 0, "x_typical"_a = py::none(), "batch"_a = 0, "max_steps"_a = py::none(),
             "max_output_mb"_a = py::none(), "parameters"_a = pgi::ParameterValues{}, "recording"_a = Recording{})
        .def(
            "_check_ensemble",
            [](const PyScheme& s, std::size_t m, std::optional<double> dt, std::optional<double> t_end,
               std::optional<std::size_t> max_steps, std::optional<double> max_output_mb, const Recording& recording) {
                pgi::plan_ensemble(*s.scheme, m, s.step_size(dt), run_length(s, t_end),
                                   limits(max_steps, max_output_mb), recording.options());
            },
            "m"_a, "dt"_a = py::none(), "t_end"_a = py::none(), "max_steps"_a = py::none(),
            "max_output_mb"_a = py::none(), "recording"_a = Recording{})
        .def("stats", &stats)
        .def("_vector_field", at_rows(&pgi::vector_field), "x"_a, "parameters"_a = pgi::ParameterValues{})
        .def("_poisson_matrices", at_rows(&pgi::poisson_matrices), "x"_a, "parameters"_a = pgi::ParameterValues{})
        .def("_hamiltonian_values", at_rows(&pgi::hamiltonian_values), "x"_a, "parameters"_a = pgi::ParameterValues{})
        .def("_casimir_values", at_rows(&pgi::casimir_values), "x"_a, "parameters"_a = pgi::ParameterValues{})
        .def(
            "_modified_hamiltonian_values",
            [](const PyScheme& s, const py::object& x, std::optional<double> dt, std::size_t upto,
               const pgi::ParameterValues& w) {
                const double h = s.step_size(dt);
                return evaluate(s, x, true, [&](const pgi::Scheme& scheme, const auto& X) {
                    return pgi::modified_hamiltonian_values(scheme, X, h, upto, w);
                });
            },
            "x"_a, "dt"_a = py::none(), "upto"_a = 4, "parameters"_a = pgi::ParameterValues{})
        .def(
            "_typical_state",
            [](const PyScheme& s, const py::object& X0) {
                const auto a = contiguous(ensemble_states(s, X0));
                return pgi::typical_state(as_matrix(a));
            },
            "X0"_a);
}
