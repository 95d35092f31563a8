#include "series/budget.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <utility>

namespace pgi {

namespace {

constexpr double mib = 1024.0 * 1024.0;

std::string megabytes(double bytes) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.0f MB", std::ceil(bytes / mib));
    return buf;
}

std::string count(double n) {
    char buf[64];
    if (n < 1e15)
        std::snprintf(buf, sizeof buf, "%.0f", n);
    else
        std::snprintf(buf, sizeof buf, "%.3g", n);
    return buf;
}

std::string seconds_text(double s) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g s", s);
    return buf;
}

// How a refusal says to raise a limit: the command line's option and the keyword of Python and SchemeValues.
std::string raise_hint(std::string_view option) {
    std::string keyword(option);
    std::replace(keyword.begin(), keyword.end(), '-', '_');
    return " (raise it with --" + std::string(option) + " or " + keyword + ")";
}

// /proc/self/statm's first two fields in bytes: the address space in use and the resident set; zeros where unreadable.
std::pair<std::size_t, std::size_t> address_space_and_resident() {
    std::ifstream in("/proc/self/statm");
    std::size_t size = 0, resident = 0;
    if (!(in >> size >> resident)) return {0, 0};
    const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    return {size * page, resident * page};
}

// Three quarters of the address-space limit, or none.
std::optional<double> address_space_budget() {
    rlimit as{};
    if (::getrlimit(RLIMIT_AS, &as) != 0 || as.rlim_cur == RLIM_INFINITY) return std::nullopt;
    return 0.75 * static_cast<double>(as.rlim_cur);
}

double physical_memory_budget() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? 0.5 * static_cast<double>(pages) * static_cast<double>(page) : 4.0 * 1024 * mib;
}

}  // namespace

std::size_t resident_memory() {
    return address_space_and_resident().second;
}

std::size_t memory_in_use(bool address_space) {
    const auto [space, resident] = address_space_and_resident();
    return address_space ? std::max(space, resident) : resident;
}

std::size_t default_memory_budget() {
    return static_cast<std::size_t>(std::min(physical_memory_budget(), address_space_budget().value_or(HUGE_VAL)));
}

bool default_memory_budget_is_address_space() {
    const std::optional<double> cap = address_space_budget();
    return cap && *cap <= physical_memory_budget();
}

double bytes_per_term(std::size_t nvars, double max_degree, double coefficient_bits) {
    // FLINT packs the exponents (and, in degrevlex, the total degree) into fields of 8, 16, 32 or 64 bits
    // that do not straddle words; a coefficient is one word, plus a GMP integer beyond 62 bits.
    double bits = 8;
    while (bits < 64 && std::ldexp(1.0, static_cast<int>(bits) - 1) <= max_degree) bits *= 2;
    const double fields = static_cast<double>(nvars) + 1, per_word = std::floor(64 / bits);
    const double exponent_words =
        bits < 64 ? std::ceil(fields / per_word) : fields * std::ceil(std::log2(max_degree + 2) / 64);
    const double coefficient = 8 + (coefficient_bits > 62 ? 16 + 8 * std::ceil(coefficient_bits / 64) : 0);
    return 8 * exponent_words + coefficient;
}

double monomials_up_to(std::size_t n, double d) {
    // binomial(n + d, min(n, d)) as a running product, stopping at infinity
    const double k = std::min(static_cast<double>(n), d);
    double r = 1;
    for (double i = 1; i <= k && std::isfinite(r); ++i) r = r * (static_cast<double>(n) + d - k + i) / i;
    return r;
}

Budget::Budget(BudgetLimits limits, ProgressSink progress)
    : limits_(limits), progress_(std::move(progress)), next_poll_(Clock::now()), next_progress_(next_poll_),
      last_(next_poll_) {}

void Budget::restart() const {
    busy_ = {};
    last_ = next_progress_ = Clock::now();
}

Budget::Stage Budget::exchange_stage(Stage s) const {
    std::swap(stage_, s);
    largest_ = 0;
    return s;
}

namespace {

std::string describe(const Budget::Stage& s) {
    if (s.K == 0) return s.name;
    return s.name + " (" + std::to_string(s.k) + " of " + std::to_string(s.K) + ")";
}

}  // namespace

double Budget::seconds() const {
    return std::chrono::duration<double>(busy_).count();
}

void Budget::refuse(BudgetExceeded::Resource r, const std::string& what) const {
    throw BudgetExceeded(r, stage_.name.empty() ? what : describe(stage_) + ": " + what);
}

bool Budget::begin_and_exceeds(double terms, double bytes_per_term) const {
    begun_ = Clock::now();
    estimated_ = true;
    return terms > static_cast<double>(limits_.max_terms) ||
           terms * bytes_per_term + static_cast<double>(resident_) > static_cast<double>(limits_.max_bytes);
}

void Budget::refuse_reserve(const std::string& operation, double terms, double bytes_per_term) const {
    if (terms > static_cast<double>(limits_.max_terms))
        refuse(BudgetExceeded::Resource::terms,
               operation + " could reach " + count(terms) + " terms, above the limit of " +
                   count(static_cast<double>(limits_.max_terms)) + raise_hint("max-terms"));
    const double bytes = terms * bytes_per_term;  // called only when the terms or these bytes are above the budget
    refuse(BudgetExceeded::Resource::memory,
           operation + " could take " + megabytes(bytes) + " (with the " + megabytes(static_cast<double>(resident_)) +
               " in use), above the memory budget of " + megabytes(static_cast<double>(limits_.max_bytes)) +
               raise_hint("max-memory-mb"));
}

void Budget::account(std::string_view operation, std::size_t terms) const {
    if (terms > limits_.max_terms)
        refuse(BudgetExceeded::Resource::terms, std::string(operation) + " reached " + std::to_string(terms) +
                                                    " terms, above the limit of " + std::to_string(limits_.max_terms) +
                                                    raise_hint("max-terms"));
    largest_ = std::max(largest_, terms);
    // NOTE: reading the clock costs as much as a small sum; every 32nd operation (and every estimated one)
    // is enough to see time and memory go by
    if (++operations_ % 32 != 0 && !estimated_) return;
    const auto now = Clock::now();
    // a gap of a second or more between operations is time spent elsewhere, unless an estimated
    // (possibly long) operation filled it
    constexpr auto idle = std::chrono::seconds(1);
    if (now - last_ < idle)
        busy_ += now - last_;
    else if (estimated_)
        busy_ += now - begun_;
    last_ = now;
    estimated_ = false;
    if (now >= next_poll_) poll(now);
}

void Budget::poll(Clock::time_point now) const {
    next_poll_ = now + std::chrono::milliseconds(20);
    const double elapsed = seconds();
    if (elapsed > limits_.max_seconds)
        refuse(BudgetExceeded::Resource::time, "the exact phase has run " + seconds_text(elapsed) +
                                                   ", above the time budget of " + seconds_text(limits_.max_seconds) +
                                                   raise_hint("max-seconds"));
    resident_ = memory_in_use(limits_.address_space);
    if (resident_ > limits_.max_bytes)
        refuse(BudgetExceeded::Resource::memory,
               "the process uses " + megabytes(static_cast<double>(resident_)) + ", above the memory budget of " +
                   megabytes(static_cast<double>(limits_.max_bytes)) + raise_hint("max-memory-mb"));
    if (progress_ && elapsed >= 1 && now >= next_progress_) {
        next_progress_ = now + std::chrono::seconds(2);
        progress_("exact phase: " + (stage_.name.empty() ? std::string() : describe(stage_) + ": ") +
                  std::to_string(largest_) + " terms, " + seconds_text(elapsed));
    }
}

BudgetLimits budget_limits(std::size_t max_terms, std::size_t max_memory_mb, double max_seconds) {
    if (!(max_seconds > 0))
        throw std::invalid_argument("max_seconds: must be positive, got " + seconds_text(max_seconds));
    BudgetLimits limits{.max_terms = max_terms, .max_seconds = max_seconds};
    if (max_memory_mb != 0) {  // (the user's budget: of the resident memory, whatever limits it)
        limits.max_bytes = std::min<std::size_t>(max_memory_mb, SIZE_MAX >> 20) << 20;
        limits.address_space = false;
    }
    return limits;
}

}  // namespace pgi
