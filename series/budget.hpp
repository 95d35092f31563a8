#pragma once
// Budget: the limits of one exact phase (terms of a polynomial, memory, wall time) and the progress of a
// long one. The rings of a phase space share one Budget; every algebra operation on their polynomials
// asks it before forming a result whose size it can predict (products, powers) and checks the clock and
// the memory after every operation. No global state: the budget travels with the ring.
#include <chrono>
#include <cstddef>
#include <functional>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>

namespace pgi {

/// Thrown before or between the operations of an exact computation that outgrows its budget; what()
/// says what, how large and the budget.
class ResourceLimitError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A refusal by a Budget: which resource ran out. what() names the stage (when one was entered), the
/// size reached or predicted, the budget and the option that raises it.
class BudgetExceeded : public ResourceLimitError {
public:
    enum class Resource { terms, memory, time };
    BudgetExceeded(Resource r, const std::string& what) : ResourceLimitError(what), resource_(r) {}
    Resource resource() const { return resource_; }

private:
    Resource resource_;
};

/// The resident memory of this process in bytes (from /proc/self/statm; 0 where it cannot be read).
std::size_t resident_memory();
/// The memory a budget counts, in bytes: the resident memory, or (address_space) the larger of it and the address
/// space in use, which libraries, stacks and malloc's reserves put 40-50 MB above the resident memory of a pgi run.
std::size_t memory_in_use(bool address_space);
/// The memory an exact phase may use by default: half the physical memory, and at most three quarters
/// of the address-space limit (RLIMIT_AS, ulimit -v) when one is set.
std::size_t default_memory_budget();
/// Whether the default budget is three quarters of an address-space limit: it then counts the address space in use,
/// which is what that limit caps (counting the resident memory, FLINT ran out of address space first).
bool default_memory_budget_is_address_space();

struct BudgetLimits {
    /// About a gigabyte of coefficients and exponents in one polynomial.
    static constexpr std::size_t default_max_terms = 20'000'000;
    /// No time limit by default in the library (a program that reuses a scene for many steppers or tests
    /// would add up their time); the pgi program sets one (60 s, --max-seconds).
    static constexpr double default_max_seconds = std::numeric_limits<double>::infinity();
    std::size_t max_terms = default_max_terms;        // terms of any one result (products: predicted)
    std::size_t max_bytes = default_memory_budget();  // of memory_in_use(address_space)
    /// What max_bytes bounds: the resident memory, or also the address space in use. By default, the address space
    /// when max_bytes' default is that of an address-space limit (default_memory_budget_is_address_space); a caller
    /// that sets max_bytes sets this too (pgi's --max-memory-mb: the resident memory).
    bool address_space = default_memory_budget_is_address_space();
    double max_seconds = default_max_seconds;  // busy time of the algebra (see Budget::seconds)
};

/// The limits a user gives (pgi's --max-terms, --max-memory-mb, --max-seconds; Python's and SchemeValues' keywords):
/// max_memory_mb = 0 keeps default_memory_budget(), another value bounds the resident memory; max_seconds must be
/// positive (infinity: no limit), std::invalid_argument otherwise.
BudgetLimits budget_limits(std::size_t max_terms, std::size_t max_memory_mb, double max_seconds);

class Budget {
public:
    /// Receives a progress line ("exact phase: S_3 (3 of 6): 12000 terms, 2.0 s") about once every two
    /// seconds once the phase has run a second; empty: no progress.
    using ProgressSink = std::function<void(const std::string&)>;
    explicit Budget(BudgetLimits limits = {}, ProgressSink progress = {});

    const BudgetLimits& limits() const { return limits_; }
    /// What runs now, named in progress lines and refusals: stage k of K, or just the name when K = 0
    /// (BudgetStage sets it).
    struct Stage {
        std::string name;
        std::size_t k = 0, K = 0;
    };
    /// Sets the stage and returns the previous one.
    Stage exchange_stage(Stage s) const;
    /// Before forming a result predicted to reach `terms` terms of `bytes_per_term` bytes each: throws
    /// BudgetExceeded when either is above the budget; describe() names the result in the message (it
    /// is called only then).
    template <class Describe>
    void reserve(double terms, double bytes_per_term, Describe describe) const {
        if (begin_and_exceeds(terms, bytes_per_term)) refuse_reserve(describe(), terms, bytes_per_term);
    }
    /// After an operation whose result has `terms` terms: checks the term bound, and every 32nd time the
    /// clock and (at most every 20 ms) the memory in use; may emit a progress line.
    void account(std::string_view operation, std::size_t terms) const;
    /// The busy time of the algebra since the budget was created or restarted: the time between
    /// operations less than a second apart, and the whole duration of an estimated operation (a product,
    /// power or substitution). Time spent elsewhere (integrating, waiting) does not count.
    double seconds() const;
    /// Starts a new exact phase with the same budget: the busy time back to zero (a program that builds
    /// several steppers from one scene gives each the whole time budget).
    void restart() const;

private:
    friend class BudgetSession;
    using Clock = std::chrono::steady_clock;
    [[noreturn]] void refuse(BudgetExceeded::Resource r, const std::string& what) const;
    bool begin_and_exceeds(double terms, double bytes_per_term) const;
    [[noreturn]] void refuse_reserve(const std::string& operation, double terms, double bytes_per_term) const;
    void poll(Clock::time_point now) const;

    BudgetLimits limits_;
    ProgressSink progress_;
    // NOTE: the state below changes inside const checks (the rings holding the budget are const);
    // an exact phase runs on one thread, and callers that may share a budget across threads hold a BudgetSession.
    mutable std::recursive_mutex session_mutex_;
    mutable std::size_t sessions_ = 0;  // the sessions under way on the thread holding session_mutex_
    mutable Stage stage_;
    mutable std::size_t largest_ = 0;
    mutable std::size_t resident_ = 0;  // memory_in_use(limits_.address_space) at the last poll
    mutable Clock::time_point next_poll_, next_progress_;
    mutable Clock::time_point last_;   // the previous account() or restart()
    mutable Clock::time_point begun_;  // the start of the estimated operation under way
    mutable bool estimated_ = false;   // reserve() was called for the operation under way
    mutable Clock::duration busy_{};
    mutable unsigned operations_ = 0;
};

/// One caller's exact computation on a budget, while it lives: it holds the budget's lock, so that the computations of
/// every ring sharing the budget (and every copy of what holds those rings) run one at a time; and the outermost
/// session on a thread restarts the budget's clock, so that each computation has the whole time budget and the time
/// between computations never counts. The lock is recursive: a computation may begin another on its thread.
class BudgetSession {
public:
    explicit BudgetSession(const Budget& b) : lock_(b.session_mutex_), budget_(b) {
        if (budget_.sessions_++ == 0) budget_.restart();
    }
    ~BudgetSession() { --budget_.sessions_; }
    BudgetSession(const BudgetSession&) = delete;
    BudgetSession& operator=(const BudgetSession&) = delete;

private:
    std::lock_guard<std::recursive_mutex> lock_;
    const Budget& budget_;
};

/// Names a stage of the exact phase while it lives, e.g. BudgetStage s(budget, "Hamilton-Jacobi term S_3", 3, 6);
/// restores the enclosing stage when it ends.
class BudgetStage {
public:
    BudgetStage(const Budget& b, std::string name, std::size_t k, std::size_t K)
        : budget_(b), previous_(b.exchange_stage({std::move(name), k, K})) {}
    ~BudgetStage() { budget_.exchange_stage(std::move(previous_)); }
    BudgetStage(const BudgetStage&) = delete;
    BudgetStage& operator=(const BudgetStage&) = delete;

private:
    const Budget& budget_;
    Budget::Stage previous_;
};

/// The bytes of one term of an fmpq_mpoly in nvars variables whose degrees stay below max_degree and
/// whose integer coefficients have coefficient_bits bits: the exponent words and the coefficient.
double bytes_per_term(std::size_t nvars, double max_degree, double coefficient_bits);
/// The number of monomials of total degree at most d in n variables, binomial(n + d, n), as a double
/// (inf when it overflows): the most terms any polynomial of degree d can have.
double monomials_up_to(std::size_t n, double d);

}  // namespace pgi
