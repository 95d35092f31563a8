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

// integrate(system, x, observer) runs one odeint integration from x.
template <class Integrate>
Outcome run_odeint(const Problem& pr, const State& x0, Samples* samples, Integrate&& integrate) {
    State x = x0;
    pr.evaluations = 0;
    Monitor monitor(pr, x0.data(), samples);
    std::size_t calls = 0;
    std::string failure;
    auto system = [&pr](const State& y, State& dydt, double) { pr.f(y.data(), dydt.data()); };
    auto observer = [&](const State& y, double t) {
        if (calls++ == 0) return;  // odeint observes the initial state too
        monitor(t, y.data());
        if (auto why = stop_reason(y.data(), y.size(), calls - 1, t); !why.empty()) throw Stop(why);
    };
    const auto start = Clock::now();
    try {
        integrate(system, x, observer);
    } catch (const std::exception& e) {  // Stop, or odeint's step_adjustment_error / no_progress_error
        failure = e.what();
    }
    return finish(std::move(x), calls ? calls - 1 : 0, start, monitor, failure);
}

Method fixed_rk4() {
    return {"odeint-rk4", true, [](const Problem& pr, const State& x0, double T, double dt, Samples* s) {
                return run_odeint(pr, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_n_steps(odeint::runge_kutta4<State>(), sys, x, 0.0, dt,
                                              static_cast<std::size_t>(std::llround(T / dt)), obs);
                });
            }};
}

Method dopri5() {
    return {"odeint-dopri5", false, [](const Problem& pr, const State& x0, double T, double tol, Samples* s) {
                return run_odeint(pr, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_adaptive(
                        odeint::make_controlled(absolute_tolerance(tol, x0), tol, odeint::runge_kutta_dopri5<State>()),
                        sys, x, 0.0, T, pr.scene.dt, obs);
                });
            }};
}

Method bulirsch_stoer() {
    return {"odeint-bs", false, [](const Problem& pr, const State& x0, double T, double tol, Samples* s) {
                return run_odeint(pr, x0, s, [&](auto& sys, State& x, auto& obs) {
                    odeint::integrate_adaptive(odeint::bulirsch_stoer<State>(absolute_tolerance(tol, x0), tol), sys, x,
                                               0.0, T, pr.scene.dt, obs);
                });
            }};
}

}  // namespace

std::vector<Method> odeint_methods() {
    return {fixed_rk4(), dopri5(), bulirsch_stoer()};
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
