#include "series/native_tier.hpp"

#include <algorithm>
#include <exception>

namespace pgi {

namespace {

// The compiler's time for a map's library: a fixed start, then per term and monomial of the source (the g++ 12 of the
// reference machine at -O2: `pgi_bench_step SCENE K --jit` prints a build's build_seconds).
constexpr double build_start_seconds = 0.1, build_seconds_per_term = 2e-4;

}  // namespace

double NativeTier::estimated_build_seconds(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    double seconds = 0;
    for (const std::size_t i : native_candidates(maps, options))
        seconds +=
            build_start_seconds + build_seconds_per_term * double(maps[i]->num_terms() + maps[i]->num_monomials());
    return seconds;
}

NativeTier::NativeTier(const std::vector<CompiledMap*>& maps, NativeOptions options)
    : options_(std::move(options)), build_ns_(estimated_build_seconds(maps, options_) * 1e9) {
    const std::vector<std::size_t> todo = native_candidates(maps, options_);
    const bool machine = std::any_of(todo.begin(), todo.end(), [&](std::size_t i) { return maps[i]->machine_code(); });
    share_ = machine ? machine_code_share : interpreter_share;
    threshold_ns_ = start_share * build_ns_ / (1 - share_);  // (spent (1 - share) >= start_share B)
}

bool NativeTier::spend(std::chrono::nanoseconds spent) {
    const long long total = spent_ns_.fetch_add(spent.count()) + spent.count();
    return double(total) >= threshold_ns_ && !starting_.load(std::memory_order_relaxed);
}

// The run's time left as it runs now, R = steps per_step; native code arrives after about the build's estimate B and
// saves (1 - native_share()) of every second after it: (R - B)(1 - native_share()) >= B.
bool NativeTier::repays(std::chrono::nanoseconds per_step, std::uint64_t steps) const {
    const double left_ns = double(per_step.count()) * double(steps);
    return (left_ns - build_ns_) * (1 - share_) >= build_ns_ && !starting_.load(std::memory_order_relaxed);
}

void NativeTier::start(const std::vector<CompiledMap*>& maps) {
    if (starting_.exchange(true)) return;
    std::lock_guard lock(mutex_);
    if (build_ || !start_failure_.empty()) return;
    try {
        build_ = std::make_shared<NativeBuild>(maps, options_);
    } catch (const std::exception& e) {
        start_failure_ = e.what();
    }
}

std::shared_ptr<NativeBuild> NativeTier::current() const {
    std::lock_guard lock(mutex_);
    return build_;
}

bool NativeTier::started() const {
    return current() != nullptr;
}

bool NativeTier::settled() const {
    std::lock_guard lock(mutex_);
    return !start_failure_.empty() || (build_ && build_->done());
}

std::size_t NativeTier::attach(const std::vector<CompiledMap*>& maps) const {
    if (const std::shared_ptr<NativeBuild> b = current()) return b->attach(maps);
    return native_count(maps);
}

void NativeTier::wait() const {
    if (const std::shared_ptr<NativeBuild> b = current()) b->wait();
}

std::string NativeTier::failure() const {
    std::lock_guard lock(mutex_);
    if (!start_failure_.empty()) return start_failure_;
    return build_ ? build_->failure() : std::string();
}

}  // namespace pgi
