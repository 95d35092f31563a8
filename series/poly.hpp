#pragma once
// Ring and Poly: multivariate polynomials over Q as value types over FLINT's fmpq_mpoly.
#include "series/budget.hpp"
#include "series/rational.hpp"

#include <flint/fmpq_mpoly.h>

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace pgi {

/// How a ring's polynomials store their terms (docs/math.md 5, "How the exact phase stores its polynomials").
/// - dense: over every variable of the ring, FLINT's packed exponent vector of at least 8 bits per variable;
/// - local: over the variables the polynomial holds, in a context of that many variables (the ring's order
///   restricted to them, so the terms keep their order), which keeps a polynomial of a few variables in a ring
///   of thousands as small as in a ring of its own: the exact phase of a sparse scene stays O(n) in memory;
/// - automatic: local from local_storage_from variables on (where the dense vectors reach 8 words).
enum class PolyStorage { automatic, dense, local };

/// Owns the fmpq_mpoly contexts of its polynomials, the names of its variables and the budget of the
/// computations in it (shared with the other rings of the same exact phase). Shared by its polynomials
/// through RingPtr, never copied.
class Ring {
public:
    static constexpr std::size_t default_max_terms = BudgetLimits::default_max_terms;
    static constexpr std::size_t local_storage_from = 64;
    /// Requires distinct, non-empty names made of letters, digits and '_', not starting with a digit.
    /// Throws std::invalid_argument naming the offending name.
    explicit Ring(std::vector<std::string> names, std::shared_ptr<const Budget> budget,
                  PolyStorage storage = PolyStorage::automatic);
    /// A ring with a budget of its own: the default limits with max_terms terms.
    explicit Ring(std::vector<std::string> names, std::size_t max_terms = default_max_terms,
                  PolyStorage storage = PolyStorage::automatic);
    ~Ring();
    Ring(const Ring&) = delete;
    Ring& operator=(const Ring&) = delete;

    /// The context over every variable (dense storage's).
    const fmpq_mpoly_ctx_struct* ctx() const { return ctx_; }
    /// Whether polynomials store their terms over the variables they hold (PolyStorage::local).
    bool local_storage() const { return !local_ctx_.empty(); }
    /// The context of a polynomial stored over m of the variables (m <= size()): ctx() for dense storage.
    const fmpq_mpoly_ctx_struct* ctx_over(std::size_t m) const {
        return local_ctx_.empty() ? ctx_ : local_ctx_[std::max<std::size_t>(m, 1) - 1].get();
    }
    /// 0, 1, ..., size() - 1: the variables of dense storage.
    std::span<const std::uint32_t> all_variables() const { return all_variables_; }
    std::size_t size() const { return names_.size(); }
    const std::vector<std::string>& names() const { return names_; }
    /// Index of a variable, or -1.
    long index_of(std::string_view name) const;
    std::size_t max_terms() const { return budget_->limits().max_terms; }
    const Budget& budget() const { return *budget_; }
    const std::shared_ptr<const Budget>& budget_ptr() const { return budget_; }

private:
    struct ContextDelete {
        void operator()(fmpq_mpoly_ctx_struct* c) const;
    };
    fmpq_mpoly_ctx_t ctx_;
    std::vector<std::string> names_;
    std::shared_ptr<const Budget> budget_;
    std::vector<std::uint32_t> all_variables_;
    std::vector<std::unique_ptr<fmpq_mpoly_ctx_struct, ContextDelete>> local_ctx_;  // over 1, 2, ..., size() variables
};
using RingPtr = std::shared_ptr<const Ring>;
inline RingPtr make_ring(std::vector<std::string> names, std::size_t max_terms = Ring::default_max_terms) {
    return std::make_shared<const Ring>(std::move(names), max_terms);
}
inline RingPtr make_ring(std::vector<std::string> names, std::shared_ptr<const Budget> budget) {
    return std::make_shared<const Ring>(std::move(names), std::move(budget));
}

/// A polynomial of Q[ring variables]. Copy is a deep copy; move swaps with an empty poly.
/// Its terms are stored over variables() (all of the ring's, or for local storage exactly those it holds):
/// get(), get_mut() and ctx() give FLINT's view, whose exponent vectors run over variables().
class Poly {
public:
    explicit Poly(RingPtr r) : ring_(std::move(r)) { fmpq_mpoly_init(p_, ctx()); }
    /// Zero, stored over the given variables (sorted, distinct) to be filled term by term through get_mut()
    /// in ctx(); for local storage, end with drop_unused_variables(). Dense storage ignores the list.
    Poly(RingPtr r, std::vector<std::uint32_t> over);
    Poly(const Poly& o) : ring_(o.ring_), vars_(o.vars_) {
        fmpq_mpoly_init(p_, ctx());
        fmpq_mpoly_set(p_, o.p_, ctx());
    }
    Poly(Poly&& o) noexcept : Poly(o.ring_) { swap(o); }
    Poly& operator=(Poly o) noexcept {
        std::swap(ring_, o.ring_);
        swap(o);
        return *this;
    }
    ~Poly() { fmpq_mpoly_clear(p_, ctx()); }

    /// The generator number var of the ring.
    static Poly gen(RingPtr r, std::size_t var);
    static Poly constant(RingPtr r, const Rational& c);
    /// Parses text in the ring's variable names: integers, rationals a/b, + - * / ^ and parentheses.
    /// Throws ParseError naming the problem and its position (unknown variable, syntax, division by zero
    /// or by a non-constant, an exponent above max_exponent, nesting deeper than max_parse_depth), and
    /// ParseBudgetError when an expansion would outgrow the ring's budget.
    static Poly parse(RingPtr r, std::string_view text, unsigned long max_exponent = 1000);

    const RingPtr& ring() const { return ring_; }
    /// The ring variables the terms are stored over (increasing).
    std::span<const std::uint32_t> variables() const {
        return ring_->local_storage() ? std::span<const std::uint32_t>(vars_) : ring_->all_variables();
    }
    /// The context of get(): over variables().
    const fmpq_mpoly_ctx_struct* ctx() const { return ring_->ctx_over(vars_.size()); }
    /// For local storage: stores the terms over the variables they hold (after filling through get_mut()).
    void drop_unused_variables();
    const fmpq_mpoly_struct* get() const { return p_; }
    fmpq_mpoly_struct* get_mut() { return p_; }

    std::size_t length() const { return static_cast<std::size_t>(fmpq_mpoly_length(p_, ctx())); }
    bool is_zero() const { return fmpq_mpoly_is_zero(p_, ctx()); }
    /// Total degree (-1 for zero).
    long total_degree() const { return fmpq_mpoly_total_degree_si(p_, ctx()); }
    /// Coefficient and exponent vector of term i (0 <= i < length()), one exponent per ring variable.
    Rational term_coeff(std::size_t i) const;
    std::vector<unsigned long> term_exponents(std::size_t i) const;
    std::string to_string() const;

    Poly& operator+=(const Poly& o);
    Poly& operator-=(const Poly& o);
    Poly& operator*=(const Rational& c);

private:
    void swap(Poly& o) noexcept {
        vars_.swap(o.vars_);
        fmpq_mpoly_swap(p_, o.p_, ctx());
    }
    RingPtr ring_;
    std::vector<std::uint32_t> vars_;  // local storage: the variables held, increasing; dense: empty
    fmpq_mpoly_t p_;
};

/// Thrown by Poly::parse; what() names the text and the problem.
struct ParseError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};
/// Thrown by Poly::parse when expanding the text would outgrow the budget; what() names the text, the
/// position of the operator and the budget's refusal.
struct ParseBudgetError : ResourceLimitError {
    using ResourceLimitError::ResourceLimitError;
};
/// The deepest nesting of parentheses, signs and divisions Poly::parse accepts.
inline constexpr std::size_t max_parse_depth = 200;

bool operator==(const Poly& a, const Poly& b);
Poly operator+(const Poly& a, const Poly& b);
Poly operator-(const Poly& a, const Poly& b);
Poly operator-(const Poly& a);
/// Every operation below checks the ring's budget: products, powers and substitutions estimate their
/// result (terms and bytes) before forming it, and every result is accounted (terms, clock, memory).
/// The product; throws BudgetExceeded before multiplying when its predicted terms (at most length(a)
/// length(b), at most the monomials of its degree) or bytes exceed the budget.
Poly operator*(const Poly& a, const Poly& b);
Poly operator*(const Rational& c, const Poly& a);
/// The sum of the pieces (all in ring): over one common denominator, the integer parts added in pairs and
/// the content reduced once, where repeated += rescales and reduces at every addition and copies a growing
/// result each time (quadratic for many pieces).
Poly sum(std::vector<Poly> pieces, const RingPtr& ring);
/// f^k, estimated before it is formed. Throws std::overflow_error when an exponent overflows.
Poly pow(const Poly& f, unsigned long k);
/// d f / d x_var.
Poly derivative(const Poly& f, std::size_t var);
/// f with every variable v replaced by images[v] (all images in f's ring, one per variable).
Poly substitute(const Poly& f, const std::vector<Poly>& images);
/// sum_j t^(first + j) c[j]: a truncated series in t evaluated at a rational t (c non-empty, one ring).
Poly sum_powers(const std::vector<Poly>& c, const Rational& t, unsigned long first = 0);
/// The double value of f at a point (one coordinate per ring variable), for checks, not for speed.
double evaluate(const Poly& f, std::span<const double> point);
/// sum_m |c_m x^m| over the terms of f (x: one value per ring variable, or the first ones, a term's factors in the
/// variables past x.size() read as 1): the size of what is summed to evaluate f at x, and a bound of |f(y)| at every
/// y with |y_v| <= |x_v|, whatever their signs. A term with a variable at 0 is 0, even where another factor overflows.
double term_size(const Poly& f, std::span<const double> x);

/// The ring variables f holds (increasing).
std::vector<std::size_t> used_variables(const Poly& f);

/// A set of variables by index, used to grade: "degree in the momenta".
using VarMask = std::vector<bool>;
/// Total degree of a monomial in the masked variables.
unsigned long masked_degree(std::span<const unsigned long> exps, const VarMask& mask);
/// The terms of f of degree exactly m (resp. at most m) in the masked variables.
Poly homogeneous_part(const Poly& f, const VarMask& mask, unsigned long m);
Poly truncate(const Poly& f, const VarMask& mask, unsigned long max_degree);
/// Highest degree of f in the masked variables (-1 for zero).
long masked_degree(const Poly& f, const VarMask& mask);

}  // namespace pgi

namespace pgi {
/// f moved to another ring: variable v of f's ring becomes variable var_map[v] of target.
Poly rename_variables(const Poly& f, RingPtr target, const std::vector<long>& var_map);
}  // namespace pgi
