#pragma once
// What every method in the peer comparison shares: the compiled vector field pi grad H (and its
// Jacobian, for the implicit peers), the quantities watched along a run, and the outcome of a run.
#include "series/compile.hpp"
#include "scheme/scene.hpp"

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
    CompiledMap field;       // pi grad H
    CompiledMap invariants;  // H, the Casimirs, then the watched quantities
    std::vector<Poly> watched;
    std::size_t num_watched;
    mutable std::size_t evaluations = 0;  // field (or Jacobian) evaluations since the last reset

    Problem(const Scene& s, const std::vector<Poly>& watched);
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

/// Runs a method `repeats` times while runs are short (< 0.2 s), keeping the fastest time: the machines are
/// shared and noisy, and the best time is the least disturbed. A method with a set-up (Method::prepare) is set up
/// once and its repeats run on it, so that every timed run after the first steps with warm caches, as the
/// peers' do (a pgi run of 500 steps after its exact phase otherwise paid ~20 us to bring its maps' code back
/// into the caches). Every repeat must end at the first run's state: one that does not (a run's state leaking
/// into the next) is a std::logic_error.
Outcome best_of(const Method& m, const Problem& pr, const State& x0, double T, double value, int repeats = 9);

/// The absolute tolerance matching a relative one at the scale of x0 (its largest component), so the
/// adaptive peers are asked the same relative accuracy at |x| = 1e-6 and at |x| = 1e6.
double absolute_tolerance(double tol, const State& x0);

/// Max-norm distance of two states.
double distance(const State& a, const State& b);

}  // namespace pgi::peers
