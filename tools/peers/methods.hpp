#pragma once
// The methods of the peer comparison: pgi at order k, GSL's odeiv2 steppers and Boost.Odeint's, all
// fed by the same compiled vector field; and the long double reference solution.
#include "tools/peers/problem.hpp"

#include <optional>

namespace pgi::peers {

/// pgi at order k with the scene's realisation ("pgi-k4"), or with the one given ("pgi-k4-radial"); jit: its maps as
/// native code (StepOptions::jit, "pgi-k4-jit"), built before the clock starts, as the exact phase.
Method pgi_method(std::size_t k, std::optional<RealisationChoice> realisation = std::nullopt, bool jit = false);
/// rk2imp (implicit midpoint), rk4imp (2-stage Gauss, order 4): fixed step; rk8pd, rkf45, msbdf: adaptive.
std::vector<Method> gsl_methods();
/// runge_kutta4: fixed step; runge_kutta_dopri5 (controlled), bulirsch_stoer: adaptive.
std::vector<Method> odeint_methods();

/// Fehlberg 7(8) (Boost.Odeint, controlled) in long double at relative tolerance tol (absolute: tol |x0|),
/// on the same compiled field (its double coefficients): the reference the errors are measured against.
State reference_solution(const Problem& pr, const State& x0, double T, long double tol);

}  // namespace pgi::peers
