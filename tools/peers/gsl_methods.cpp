// GSL's odeiv2 steppers as methods of the comparison: only this file (and the program) includes GSL.
#include "tools/peers/methods.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace pgi::peers {

namespace {

// pgi's compiled field and Jacobian through pgi's interpreter (the "-pgifield" variants: the harness before issue 33)
int pgi_rhs(double, const double y[], double dydt[], void* p) {
    static_cast<const Problem*>(p)->f(y, dydt);
    return GSL_SUCCESS;
}

int pgi_jac(double, const double y[], double* dfdy, double dfdt[], void* p) {
    const auto* pr = static_cast<const Problem*>(p);
    pr->jacobian().eval(y, dfdy);
    for (std::size_t i = 0; i < pr->n; ++i) dfdt[i] = 0.0;
    return GSL_SUCCESS;
}

// The peers' own C functions, counted: for the monitored run only (the timed runs call them directly).
int counted_rhs(double t, const double y[], double dydt[], void* p) {
    const auto* pr = static_cast<const Problem*>(p);
    ++pr->evaluations;
    return pr->rhs.rhs(t, y, dydt, nullptr);
}

int counted_jac(double t, const double y[], double* dfdy, double dfdt[], void* p) {
    const auto* pr = static_cast<const Problem*>(p);
    ++pr->evaluations;
    return pr->rhs.jacobian(t, y, dfdy, dfdt, nullptr);
}

// The system GSL integrates: the compiled C functions themselves, as a GSL user passes them (counted when the run is
// monitored), or pgi's field.
gsl_odeiv2_system system_of(const Problem& pr, bool pgi_field) {
    auto* params = const_cast<Problem*>(&pr);
    if (pgi_field) return {pgi_rhs, pgi_jac, pr.n, params};
    if (!pr.rhs.rhs) throw std::logic_error("the peers' C right-hand side was not compiled");
    const bool jacobian = pr.rhs.jacobian != nullptr;  // (compiled only where an implicit peer runs)
    if (pr.monitoring) return {counted_rhs, jacobian ? counted_jac : nullptr, pr.n, params};
    return {pr.rhs.rhs, pr.rhs.jacobian, pr.n, nullptr};
}

// value: the step (fixed) or the relative tolerance (adaptive, from a first step of the scene's dt)
Outcome run_gsl(const gsl_odeiv2_step_type* type, bool fixed, bool pgi_field, const Problem& pr, const State& x0,
                double T, double value, Samples* samples) {
    gsl_odeiv2_system sys = system_of(pr, pgi_field);
    if (!sys.jacobian && needs_jacobian(type->name))
        throw std::logic_error("the peers' C right-hand side was compiled without its Jacobian");
    // the implicit steppers read the Jacobian: pgi's is built here, outside the timed run (once per problem)
    if (pgi_field && needs_jacobian(type->name)) pr.jacobian();
    double h = fixed ? value : pr.scene.dt;
    const double eps_rel = fixed ? 1e-14 : value, eps_abs = absolute_tolerance(eps_rel, x0);
    // NOTE: GSL's implicit steppers (rk4imp, msbdf) work only through a driver, which owns step, control and evolve.
    gsl_odeiv2_driver* d = gsl_odeiv2_driver_alloc_y_new(&sys, type, h, eps_abs, eps_rel);
    if (d == nullptr) throw std::runtime_error("GSL could not allocate a driver");
    State x = x0;
    pr.evaluations = 0;
    Monitor monitor(pr, x0.data(), samples);
    double t = 0;
    std::size_t steps = 0;
    std::string failure;
    const auto N = static_cast<std::size_t>(std::llround(T / value));
    const auto start = Clock::now();
    while (fixed ? steps < N : t < T) {
        const int status = fixed ? gsl_odeiv2_evolve_apply_fixed_step(d->e, nullptr, d->s, &sys, &t, h, x.data())
                                 : gsl_odeiv2_evolve_apply(d->e, d->c, d->s, &sys, &t, T, &h, x.data());
        if (status != GSL_SUCCESS) {
            failure = fmt::format("GSL status {} ({}) at t = {:g}", status, gsl_strerror(status), t);
            break;
        }
        ++steps;
        monitor(t, x.data());
        if (failure = stop_reason(x.data(), x.size(), steps, t); !failure.empty()) break;
    }
    Outcome o = finish(std::move(x), steps, start, monitor, failure);
    gsl_odeiv2_driver_free(d);
    return o;
}

Method gsl(std::string name, const gsl_odeiv2_step_type* type, bool fixed, bool pgi_field) {
    return {std::move(name) + (pgi_field ? pgi_field_suffix : ""), fixed,
            [type, fixed, pgi_field](const Problem& pr, const State& x0, double T, double value, Samples* s) {
                return run_gsl(type, fixed, pgi_field, pr, x0, T, value, s);
            }};
}

}  // namespace

std::vector<Method> gsl_methods(bool pgi_field) {
    gsl_set_error_handler_off();
    return {
        gsl("rk2imp", gsl_odeiv2_step_rk2imp, true, pgi_field), gsl("rk4imp", gsl_odeiv2_step_rk4imp, true, pgi_field),
        gsl("rk8pd", gsl_odeiv2_step_rk8pd, false, pgi_field), gsl("rkf45", gsl_odeiv2_step_rkf45, false, pgi_field),
        gsl("msbdf", gsl_odeiv2_step_msbdf, false, pgi_field)};
}

}  // namespace pgi::peers
