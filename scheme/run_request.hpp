#pragma once
// One validation of a run's request for every surface (the command line, Python, C++, ensembles, Dask):
// dt, t_end, the recording stride, event samples and the number of trajectories are checked, and the run's
// steps, recorded rows and kept bytes estimated, before any work, against one set of limits with one set of
// messages. Surfaces translate the two errors only: InputError (a value outside its domain: exit 2,
// pgi.InputError) and RunBudgetError (a run above its budget: exit 4, pgi.ResourceLimitError).
#include "scheme/input.hpp"
#include "series/budget.hpp"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

namespace pgi {

/// A run refused before any work because it is larger than its budget: what() names the quantity, its size,
/// the limit and how to raise it.
class RunBudgetError : public ResourceLimitError {
public:
    using ResourceLimitError::ResourceLimitError;
};

/// A run stopped because its caller asked (RunCancel): nothing it computed is returned.
class RunInterrupted : public std::runtime_error {
public:
    RunInterrupted() : std::runtime_error("interrupted") {}
};

/// What a run may take. The defaults are every surface's defaults; each surface lets its user raise them.
struct RunLimits {
    /// 1e8 steps: about 30 s at the fastest step measured and minutes for larger scenes (--max-steps, max_steps=).
    static constexpr std::size_t default_max_steps = 100'000'000;
    /// 1 GiB of recorded rows and ensemble results kept in memory (--max-output-mb, max_output_mb=).
    static constexpr double default_max_output_mb = 1024;
    /// Sign tests of an event per step: past this the dense output dominates any step.
    static constexpr std::size_t max_event_samples = 10'000;
    /// Events of one run: each crossing is located with every event's value (a step where m events cross costs m^2
    /// evaluations), so 30000 events took 17 s a step; sections and stops need a few.
    static constexpr std::size_t max_events = 256;
    std::size_t max_steps = default_max_steps;     // steps of one trajectory
    double max_output_mb = default_max_output_mb;  // bytes kept / 2^20
};

/// A run as a surface was asked for it. every = 0 records only the end state (an ensemble's default).
struct RunRequest {
    double dt = 0;
    double t_end = 0;
    std::size_t every = 1;
    std::size_t dim = 0;         // coordinates
    std::size_t invariants = 1;  // values kept per recorded row besides t and x (H, the Casimirs, ...)
    std::size_t trajectories = 1;
    std::size_t event_samples = 1;
    std::size_t events = 0;          // event polynomials watched
    std::span<const double> t_eval;  // times to record at instead of every `every`-th step (empty: every applies)
    bool tangent = false;            // each trajectory keeps its tangent map (dim x dim)
};

/// What the run will do, known before it starts.
struct RunPlan {
    std::size_t steps = 0;    // whole steps of dt reaching t_end (steps_to_reach)
    std::size_t records = 0;  // rows recorded per trajectory (fewer when it ends early)
    double output_mb = 0;     // what the run keeps in memory, all trajectories together
};

/// Whole steps of size dt that reach t_end: 0 at t_end = 0, else max(1, ceil(t_end / dt - 1e-9)) (the 1e-9
/// keeps t_end = 10, dt = 0.1 at 100 steps); +inf past what a size_t holds (plan_run refuses it).
double steps_to_reach(double t_end, double dt);

/// The recording rule of every run that records states by a stride (single runs, ensembles on lanes and threads,
/// Lyapunov spectra): the state after step n is recorded when every > 0 and every divides n or the state is the
/// run's last (step N, or a terminal event's); the start, n = 0, included. every = 0 records no state on the way.
constexpr bool records_step(std::size_t n, bool last, std::size_t every) {
    return every != 0 && (n % every == 0 || last);
}
/// The steps records_step keeps for a run of N steps, in increasing order (none at every = 0): 0, every, 2 every,
/// ..., and N; f(n) for each, in O(N / every).
template <class F>
void for_each_recorded_step(std::size_t N, std::size_t every, F&& f) {
    if (every == 0) return;
    std::size_t n = 0;
    for (; n <= N; n += every) f(n);
    if (n - every != N) f(N);
}
/// The rows a run of `steps` steps records: for_each_recorded_step's count, steps / every + 1, one more when every
/// does not divide steps; 1 at every = 0 (a run that records by no stride still keeps its end state).
std::size_t recorded_steps(std::size_t steps, std::size_t every);

/// Checks r (InputError naming "dt", "t_end", "every", "event_samples", "trajectories" or "t_eval" on a value outside
/// its domain: requested times must be finite, strictly increasing and within [0, t_end]) and its size (RunBudgetError
/// above limits: steps, output, event samples), before any work.
RunPlan plan_run(const RunRequest& r, const RunLimits& limits = {});

/// A flag a run polls after every step (a relaxed load): once set, the run stops and throws
/// RunInterrupted. Set from another thread or a signal handler (lock-free).
class RunCancel {
public:
    void cancel() { flag_.store(true, std::memory_order_relaxed); }
    bool cancelled() const { return flag_.load(std::memory_order_relaxed); }
    /// Throws RunInterrupted once cancelled.
    void check() const {
        if (cancelled()) throw RunInterrupted();
    }

private:
    std::atomic<bool> flag_{false};
};

/// What a caller controls of a run besides its request: its budgets and a flag to stop it.
struct RunControl {
    RunLimits limits;
    const RunCancel* cancel = nullptr;  // polled after every step; null: never stopped
};

}  // namespace pgi
