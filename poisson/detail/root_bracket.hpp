#pragma once
// A root of a scalar function inside a sign-changing bracket, to round-off: Newton's method kept
// inside the bracket, with a bisection whenever Newton would leave it or fails to halve the bracket
// (Numerical Recipes' rtsafe). Header-only, no dependency: the core library links only FLINT and Eigen.
#include <cmath>
#include <limits>
#include <utility>

namespace pgi {

/// f_and_df(x) returns {f(x), f'(x)}. Requires fa = f(a), fb = f(b) with fa fb <= 0 and a < b. Returns
/// x in [a, b] with f(x) = 0, or a point of a bracket of width at most a few ulps of x (or below the
/// smallest normal double) where f changes sign. Newton converges quadratically near a simple root;
/// the cap of 2200 evaluations is what bisection alone needs to narrow any bracket of doubles.
template <class F>
double find_root(F&& f_and_df, double a, double b, double fa, double fb) {
    if (fa == 0) return a;
    if (fb == 0) return b;
    double lo = fa < 0 ? a : b, hi = fa < 0 ? b : a;  // f(lo) < 0 < f(hi); lo may exceed hi
    double x = a - fa * (b - a) / (fb - fa);          // regula falsi start
    if (!(std::fmin(a, b) < x && x < std::fmax(a, b))) x = 0.5 * (a + b);
    double dx_old = std::fabs(b - a), dx = dx_old;
    const double eps = std::numeric_limits<double>::epsilon();
    for (int iteration = 0; iteration < 2200; ++iteration) {
        const auto [fx, dfx] = f_and_df(x);
        if (fx == 0) return x;
        (fx < 0 ? lo : hi) = x;
        const double width = std::fabs(hi - lo);
        if (width <= 4 * eps * std::fmax(std::fabs(lo), std::fabs(hi)) || width <= std::numeric_limits<double>::min())
            return x;
        const double newton = x - fx / dfx;
        const bool inside = std::isfinite(newton) && std::fmin(lo, hi) < newton && newton < std::fmax(lo, hi);
        dx_old = dx;
        // Newton unless it leaves the bracket or would not halve the step before last (slow convergence)
        const double next = inside && std::fabs(2 * fx) <= std::fabs(dx_old * dfx) ? newton : 0.5 * (lo + hi);
        dx = std::fabs(next - x);
        if (dx <= 2 * eps * std::fabs(x) || next == x) return next;
        x = next;
    }
    return x;
}

}  // namespace pgi
