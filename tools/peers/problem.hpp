#pragma once
// What every method in the peer comparison shares: the vector field pi grad H (and its Jacobian, for the implicit
// peers) as the peers' own compiled C (tools/peers/compiled_rhs.hpp) and as pgi's compiled map (the long double
// reference, the peers fed through pgi's interpreter on request), the quantities watched along a run, and the
// outcome of a run.
#include "scheme/scene.hpp"
#include "series/compile.hpp"
#include "tools/peers/compiled_rhs.hpp"

#include <array>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace pgi::peers {

using Clock = std::chrono::steady_clock;
using Samples = std::vector<std::array<double, 3>>;  // t, relative energy error, first Casimir's relative error
using State = std::vector<double>;

struct Problem {
    const Scene& scene;
    std::size_t n;
    CompiledMap field;       // pi grad H, pgi's compiled map (its interpreter)
    CompiledMap invariants;  // H, the Casimirs, then the watched quantities
    std::vector<Poly> watched;
    std::size_t num_watched;
    /// pi grad H and its Jacobian as the peers' users write them: C from the same exact polynomials, compiled by the
    /// system C compiler (cc -O3 -march=native) and loaded; what the peers call, unless fed pgi's field on request.
    CompiledRhs rhs;
    mutable std::size_t evaluations = 0;  // field (or Jacobian) evaluations since the last reset (monitored runs)
    /// Whether runs watch the invariants every step (Monitor) and count evaluations. best_of turns it off for its
    /// timed runs: a user timing a run to T watches nothing, and no peer's loop then runs any pgi code.
    mutable bool monitoring = true;

    /// What the peers run need of their C right-hand side: nothing (pgi alone), the field (explicit peers), or the
    /// field and its Jacobian (rk2imp, rk4imp, msbdf: needs_jacobian).
    enum class PeerRhs { none, field, field_and_jacobian };
    /// Builds pgi's maps and the peers' C right-hand side (NativeCodeError if the C compiler cannot build it).
    Problem(const Scene& s, const std::vector<Poly>& watched, PeerRhs peer_rhs = PeerRhs::field_and_jacobian,
            const RhsCompileOptions& rhs_options = {});
    /// pgi's compiled field through pgi's interpreter, counted: the peers' right-hand side before issue 33, kept for
    /// the "-pgifield" variants and the long double reference.
    void f(const double* x, double* dxdt) const {
        ++evaluations;
        field.eval(x, dxdt);
    }
    /// pi grad H's Jacobian, row-major (as GSL wants dfdy), built when an implicit peer first asks: its n^2
    /// entries (zero polynomials for the most part) are a lattice's largest memory where only explicit peers run.
    const CompiledMap& jacobian() const;

private:
    mutable std::once_flag jacobian_built_;
    mutable CompiledMap jacobian_;
};

/// Follows the invariants along a run: the largest relative error of H and of each Casimir, the
/// watched quantities' final/initial ratios, and (optionally) log-spaced samples for drift plots.
struct Monitor {
    const Problem& pr;
    std::vector<double> initial, value, worst;
    std::vector<double> scale;  // each invariant's size of terms at x0, what its error is relative to
    Samples* samples = nullptr;
    double next_sample = 0;
    Monitor(const Problem& p, const double* x0, Samples* s);
    void operator()(double t, const double* x);
    double energy_error() const { return worst[0]; }
    double casimir_error() const;  // the worst Casimir (0 without Casimirs)
    std::vector<double> watched_ratios() const;

private:
    double relative_change(std::size_t i) const;  // of invariant i, as pgi's own reports measure it
};

struct Outcome {
    State x;
    double seconds = 0, energy_error = 0, casimir_error = 0;
    double setup_seconds = 0;     // pgi: the exact phase and compilation, before the timed run
    std::size_t native_maps = 0;  // pgi: the step's compiled maps running native code at the end of the (fastest) run
    std::vector<double> watched;  // final / initial value of each watched quantity
    std::size_t steps = 0, evaluations = 0;
    bool ok = true;
    std::string failure;  // why the run stopped, if it did
};

/// Why a run must stop after `steps` steps at t with state x (non-finite, or past the step budget of
/// 5e7 steps), or empty if it may go on: one rule for every peer's loop.
std::string stop_reason(const double* x, std::size_t n, std::size_t steps, double t);

/// The outcome of a run that ended at x after `steps` steps, started at `start` (clock read now),
/// with the monitor's errors and the problem's evaluation count.
Outcome finish(State x, std::size_t steps, Clock::time_point start, const Monitor& monitor, std::string failure = {});

/// A run at one value of the ladder, set up: x0, T and the samples wanted -> the outcome, its stepping timed.
using PreparedRun = std::function<Outcome(const State& x0, double T, Samples*)>;

/// A method of the comparison: a fixed step (the ladder's value is dt) or an adaptive one (a tolerance).
struct Method {
    std::string name;
    bool fixed_step;
    std::function<Outcome(const Problem&, const State& x0, double T, double value, Samples*)> run;
    /// Where a run has a set-up worth doing once (pgi: the exact phase and the compilation), the run at value set up
    /// for starts near x0; run does the same set-up each time. Empty for the peers, whose set-up is a driver's.
    std::function<PreparedRun(const Problem&, const State& x0, double value)> prepare = {};
};

/// Whether the peer named (its own name, "rk4imp") calls the Jacobian: GSL's implicit steppers.
bool needs_jacobian(const std::string& peer);

/// A method's run at one value, as a user times it: a first run with the monitor on (the outcome: final state, steps,
/// the invariants' errors, evaluations; its time is not used, it warms the caches), then timed runs with the monitor
/// off (pr.monitoring: nothing but the method's own loop inside the clock), at least one and at most `repeats`, while
/// their total time is under 0.3 s; the outcome's seconds is the fastest (the machines are shared and noisy: the best
/// time is the least disturbed). A method with a set-up (Method::prepare) is set up once and every run steps on it.
/// Every run must end at the first run's state: one that does not (a run's state leaking into the next) is a
/// std::logic_error. A first run that fails is the outcome, timed as it ran.
Outcome best_of(const Method& m, const Problem& pr, const State& x0, double T, double value, int repeats = 25);

/// The absolute tolerance matching a relative one at the scale of x0 (its largest component), so the
/// adaptive peers are asked the same relative accuracy at |x| = 1e-6 and at |x| = 1e6.
double absolute_tolerance(double tol, const State& x0);

/// Max-norm distance of two states.
double distance(const State& a, const State& b);

}  // namespace pgi::peers
