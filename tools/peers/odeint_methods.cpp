// Boost.Odeint's steppers as methods of the comparison, and the long double reference solution.
#include "tools/peers/methods.hpp"

#include <boost/numeric/odeint.hpp>
#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace pgi::peers {

namespace odeint = boost::numeric::odeint;

namespace {

// Thrown by the observer to stop a run that has gone non-finite or exceeded its step budget.
struct Stop : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// integrate(system, x, observer) runs one odeint integration from x. The system is the compiled C right-hand side,
// called through its pointer (counted in a monitored run), or with pgi_field pgi's field through pgi's interpreter.
template <class Integrate>
Outcome run_odeint(const Problem& pr, bool pgi_field, const State& x0, Samples* samples, Integrate&& integrate) {
    State x = x0;
    pr.evaluations = 0;
    Monitor monitor(pr, x0.data(), samples);
    std::size_t calls = 0;
    std::string failure;
    if (!pgi_field && !pr.rhs.rhs) throw std::logic_error("the peers' C right-hand side was not compiled");
    auto observer = [&](const State& y, double t) {
        if (calls++ == 0) return;  // odeint observes the initial state too
        monitor(t, y.data());
        if (auto why = stop_reason(y.data(), y.size(), calls - 1, t); !why.empty()) throw Stop(why);
    };
    Clock::time_point start;
    const auto run = [&](auto system) {
        start = Clock::now();
        try {
            integrate(system, x, observer);
        } catch (const std::exception& e) {  // Stop, or odeint's step_adjustment_error / no_progress_error
            failure = e.what();
        }
    };
    const RhsFunction rhs = pr.rhs.rhs;
    if (pgi_field)
        run([&pr](const State& y, State& dydt, double) { pr.f(y.data(), dydt.data()); });
    else if (pr.monitoring)
        run([&pr, rhs](const State& y, State& dydt, double t) {
            ++pr.evaluations;
            rhs(t, y.data(), dydt.data(), nullptr);
        });
    else  // as a user's system: the compiled function, nothing else
        run([rhs](const State& y, State& dydt, double t) { rhs(t, y.data(), dydt.data(), nullptr); });
    return finish(std::move(x), calls ? calls - 1 : 0, start, monitor, failure);
}

std::string named(const char* name, bool pgi_field) {
    return std::string(name) + (pgi_field ? pgi_field_suffix : "");
}

Method fixed_rk4(bool pgi_field) {
    return {named("odeint-rk4", pgi_field), true,
            [pgi_field](const Problem& pr, const State& x0, double T, double dt, Samples* s) {
                return run_odeint(pr, pgi_field, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_n_steps(odeint::runge_kutta4<State>(), sys, x, 0.0, dt,
                                              static_cast<std::size_t>(std::llround(T / dt)), obs);
                });
            }};
}

Method dopri5(bool pgi_field) {
    return {named("odeint-dopri5", pgi_field), false,
            [pgi_field](const Problem& pr, const State& x0, double T, double tol, Samples* s) {
                return run_odeint(pr, pgi_field, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_adaptive(
                        odeint::make_controlled(absolute_tolerance(tol, x0), tol, odeint::runge_kutta_dopri5<State>()),
                        sys, x, 0.0, T, pr.scene.dt, obs);
                });
            }};
}

Method fehlberg78(bool pgi_field) {
    return {named("odeint-rkf78", pgi_field), false,
            [pgi_field](const Problem& pr, const State& x0, double T, double tol, Samples* s) {
                return run_odeint(pr, pgi_field, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_adaptive(odeint::make_controlled(absolute_tolerance(tol, x0), tol,
                                                                       odeint::runge_kutta_fehlberg78<State>()),
                                               sys, x, 0.0, T, pr.scene.dt, obs);
                });
            }};
}

Method bulirsch_stoer(bool pgi_field) {
    return {named("odeint-bs", pgi_field), false,
            [pgi_field](const Problem& pr, const State& x0, double T, double tol, Samples* s) {
                return run_odeint(pr, pgi_field, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_adaptive(odeint::bulirsch_stoer<State>(absolute_tolerance(tol, x0), tol), sys, x,
                                               0.0, T, pr.scene.dt, obs);
                });
            }};
}

}  // namespace

std::vector<Method> odeint_methods(bool pgi_field) {
    return {fixed_rk4(pgi_field), dopri5(pgi_field), fehlberg78(pgi_field), bulirsch_stoer(pgi_field)};
}

State reference_solution(const Problem& pr, const State& x0, double T, long double tol) {
    using LState = std::vector<long double>;
    std::vector<long double> scratch;
    auto system = [&](const LState& y, LState& dydt, long double) { pr.field.eval(y.data(), dydt.data(), scratch); };
    LState x(x0.begin(), x0.end());
    const auto abs_tol = static_cast<long double>(absolute_tolerance(1.0, x0)) * tol;
    odeint::integrate_adaptive(
        odeint::make_controlled(abs_tol, tol, odeint::runge_kutta_fehlberg78<LState, long double>()), system, x, 0.0L,
        static_cast<long double>(T), static_cast<long double>(pr.scene.dt));
    return State(x.begin(), x.end());
}

}  // namespace pgi::peers
