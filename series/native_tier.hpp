#pragma once
// NativeTier: when a set of compiled maps (a step's) is worth native code under NativePolicy::automatic. A JIT's tier
// rule: the maps run machine code or the interpreter (no latency for short runs); the time spent in them is sampled,
// and once the time native code would have saved reaches a share of what the compiler is expected to take, native code
// is built in the background (NativeBuild) and every user of the maps switches to it when it is ready (the same bits,
// so a run cannot tell where it switched). Shared by a stepper and its copies (std::shared_ptr), so the time of every
// run of a Scheme's step counts, from any thread.
#include "series/native.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pgi {

class NativeTier {
public:
    /// The compiler's time for the maps not native yet, estimated from their size: per map (a library each) a fixed
    /// start plus a time per term and monomial (the compiler's time grows with the source, NativeOptions::max_size),
    /// measured with pgi_bench_step --jit. 0 when every map that options would compile is native.
    static double estimated_build_seconds(const std::vector<CompiledMap*>& maps, const NativeOptions& options = {});
    /// The build starts once the time native code would have saved over the sampled steps, (1 - native_share()) of
    /// them, reaches this share of the estimated build (with the interpreter's share, after half the build's time).
    static constexpr double start_share = 0.125;

    explicit NativeTier(const std::vector<CompiledMap*>& maps, NativeOptions options = {});
    NativeTier(const NativeTier&) = delete;
    NativeTier& operator=(const NativeTier&) = delete;
    /// Adds time spent in the maps' steps (from any thread); true when the total has passed the share and no build
    /// was started: the caller then start()s it. Allocates nothing.
    bool spend(std::chrono::nanoseconds spent);
    /// A step with native code takes at most this share of the interpreted step's time (measured 1/1.8 to 1/1.4 on
    /// the bundled scenes at k = 10: docs/math.md 6) ...
    static constexpr double interpreter_share = 0.75;
    /// ... and this share of the step with machine code (series/machine_code.hpp; measured 0.93-1.01 on the rigid
    /// body, Lotka-Volterra and Henon-Heiles at k = 10, 30 000 steps, pgi_bench_step --jit against --default).
    static constexpr double machine_code_share = 0.95;
    /// The share for these maps: machine_code_share if any map the build would compile runs machine code.
    double native_share() const { return share_; }
    /// Whether a run that will take `steps` more steps of `per_step` each (as it runs now) repays a build started now: the
    /// time native code saves once the build is done (after about its estimate) is at least the build's estimate. No
    /// build was started yet. The caller then start()s it, before spend() would.
    bool repays(std::chrono::nanoseconds per_step, std::uint64_t steps) const;
    /// Starts the build from maps (the maps this tier was made for, or a copy of them in the same order), once: later
    /// calls do nothing. Never throws: a build that cannot start is a failure().
    void start(const std::vector<CompiledMap*>& maps);
    /// The build ended (with native code or a failure): no more spend() is needed.
    bool settled() const;
    /// Gives maps their native code once it is built (NativeBuild::attach); how many of maps run native code (those
    /// kept from the cache before, and after a failed build).
    std::size_t attach(const std::vector<CompiledMap*>& maps) const;
    /// The time sampled so far, and whether a build was started.
    std::chrono::nanoseconds spent() const { return std::chrono::nanoseconds(spent_ns_.load()); }
    bool started() const;
    /// Waits for a started build to end (tests, benchmarks); returns at once if none was started.
    void wait() const;
    /// Why native code could not be built ("" if it was, or is not yet known).
    std::string failure() const;

private:
    std::shared_ptr<NativeBuild> current() const;
    NativeOptions options_;
    double share_, threshold_ns_, build_ns_;
    std::atomic<long long> spent_ns_{0};
    std::atomic<bool> starting_{false};
    mutable std::mutex mutex_;  // guards build_
    std::shared_ptr<NativeBuild> build_;
    std::string start_failure_;
};

}  // namespace pgi
