#pragma once
// The methods of the peer comparison: pgi at order k through its C++ API, GSL's odeiv2 steppers and Boost.Odeint's on
// the peers' own compiled C right-hand side (tools/peers/compiled_rhs.hpp); and the long double reference solution.
#include "tools/peers/problem.hpp"

#include <optional>

namespace pgi::peers {

/// pgi at order k with the scene's realisation ("pgi-k4"), or with the one given ("pgi-k4-radial"), as a user runs it:
/// a Scheme of the scene's pi, H and Casimirs at order k in its default configuration (native code as
/// NativePolicy::automatic decides), scheme.stepper(dt, x0) built before the clock starts (reported as setup_seconds:
/// the exact phase), then integrate_steps (stepper.step, Kahan summation). jit: the Scheme made with
/// NativePolicy::always (its maps as native code, built in the set-up: "pgi-k4-jit").
Method pgi_method(std::size_t k, std::optional<RealisationChoice> realisation = std::nullopt, bool jit = false);
/// What the "-pgifield" variants of the peers add to their names ("rk8pd-pgifield").
inline constexpr const char* pgi_field_suffix = "-pgifield";

/// rk2imp (implicit midpoint), rk4imp (2-stage Gauss, order 4): fixed step; rk8pd, rkf45, msbdf: adaptive. They call
/// the problem's compiled C right-hand side (Problem::rhs) directly; with pgi_field, pgi's compiled field through
/// pgi's interpreter instead (named "-pgifield": the comparison before issue 33, which is not how GSL is used).
std::vector<Method> gsl_methods(bool pgi_field = false);
/// runge_kutta4: fixed step; runge_kutta_dopri5 and runge_kutta_fehlberg78 (controlled), bulirsch_stoer: adaptive
/// ("odeint-rk4", "odeint-dopri5", "odeint-rkf78", "odeint-bs"). The system calls the compiled
/// C right-hand side through its function pointer (as with a right-hand side compiled apart: no inlining into the
/// stepper); pgi_field as for gsl_methods.
std::vector<Method> odeint_methods(bool pgi_field = false);

/// Fehlberg 7(8) (Boost.Odeint, controlled) in long double at relative tolerance tol (absolute: tol |x0|),
/// on the same compiled field (its double coefficients): the reference the errors are measured against.
State reference_solution(const Problem& pr, const State& x0, double T, long double tol);

}  // namespace pgi::peers
