// GSL's odeiv2 steppers as methods of the comparison: only this file (and the program) includes GSL.
#include "tools/peers/methods.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <cmath>
#include <fmt/format.h>

namespace pgi::peers {

namespace {

int rhs(double, const double y[], double dydt[], void* p) {
    static_cast<const Problem*>(p)->f(y, dydt);
    return GSL_SUCCESS;
}

int jac(double, const double y[], double* dfdy, double dfdt[], void* p) {
    const auto* pr = static_cast<const Problem*>(p);
    pr->jacobian().eval(y, dfdy);
    for (std::size_t i = 0; i < pr->n; ++i) dfdt[i] = 0.0;
    return GSL_SUCCESS;
}

// value: the step (fixed) or the relative tolerance (adaptive, from a first step of the scene's dt)
Outcome run_gsl(const gsl_odeiv2_step_type* type, bool fixed, const Problem& pr, const State& x0, double T,
                double value, Samples* samples) {
    gsl_odeiv2_system sys{rhs, jac, pr.n, const_cast<Problem*>(&pr)};
    // the implicit steppers read the Jacobian: built here, outside the timed run (once per problem)
    if (type == gsl_odeiv2_step_rk2imp || type == gsl_odeiv2_step_rk4imp || type == gsl_odeiv2_step_msbdf)
        pr.jacobian();
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

Method gsl(std::string name, const gsl_odeiv2_step_type* type, bool fixed) {
    return {std::move(name), fixed,
            [type, fixed](const Problem& pr, const State& x0, double T, double value, Samples* s) {
                return run_gsl(type, fixed, pr, x0, T, value, s);
            }};
}

}  // namespace

std::vector<Method> gsl_methods() {
    gsl_set_error_handler_off();
    return {gsl("rk2imp", gsl_odeiv2_step_rk2imp, true), gsl("rk4imp", gsl_odeiv2_step_rk4imp, true),
            gsl("rk8pd", gsl_odeiv2_step_rk8pd, false), gsl("rkf45", gsl_odeiv2_step_rkf45, false),
            gsl("msbdf", gsl_odeiv2_step_msbdf, false)};
}

}  // namespace pgi::peers
