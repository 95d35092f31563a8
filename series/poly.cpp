#include "series/poly.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

namespace pgi {

namespace {

bool is_identifier(std::string_view s) {
    if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
    for (char c : s)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
    return true;
}

void require_same_ring(const Poly& a, const Poly& b, const char* where) {
    if (a.ring() != b.ring()) throw std::invalid_argument(std::string(where) + ": operands belong to different rings");
}

// The result of an operation, accounted by its ring's budget (terms, clock, memory).
Poly accounted(Poly r, std::string_view operation) {
    r.ring()->budget().account(operation, r.length());
    return r;
}

double coefficient_bits(const Poly& f) {
    return static_cast<double>(std::abs(fmpz_mpoly_max_bits(f.get()->zpoly)));
}

// The total degree, for estimates: in the rings' degree-first order the leading term has it, which is
// cheaper than FLINT's scan of every term (exponents beyond a word fall back to the scan).
double degree(const Poly& f) {
    if (f.is_zero()) return 0;
    if (f.get()->zpoly->bits > FLINT_BITS) return static_cast<double>(std::max(f.total_degree(), 0L));
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), 0, f.ctx());
    double d = 0;
    for (ulong v : e) d += static_cast<double>(v);
    return d;
}

std::string terms_text(std::size_t n) { return std::to_string(n) + "-term"; }

}  // namespace

Ring::Ring(std::vector<std::string> names, std::size_t max_terms)
    : Ring(std::move(names), std::make_shared<const Budget>(BudgetLimits{.max_terms = max_terms})) {}

Ring::Ring(std::vector<std::string> names, std::shared_ptr<const Budget> budget)
    : names_(std::move(names)), budget_(std::move(budget)) {
    if (!budget_) throw std::invalid_argument("pgi::Ring: no budget");
    for (std::size_t i = 0; i < names_.size(); ++i) {
        if (!is_identifier(names_[i]))
            throw std::invalid_argument("variable name '" + names_[i] + "' is not an identifier");
        for (std::size_t j = 0; j < i; ++j)
            if (names_[i] == names_[j]) throw std::invalid_argument("variable name '" + names_[i] + "' is repeated");
    }
    // NOTE: FLINT needs at least one variable; a ring of zero names still gets a context of one.
    fmpq_mpoly_ctx_init(ctx_, static_cast<slong>(std::max<std::size_t>(names_.size(), 1)), ORD_DEGREVLEX);
}

long Ring::index_of(std::string_view name) const {
    for (std::size_t i = 0; i < names_.size(); ++i)
        if (names_[i] == name) return static_cast<long>(i);
    return -1;
}

Poly Poly::gen(RingPtr r, std::size_t var) {
    if (var >= r->size()) throw std::out_of_range("pgi::Poly::gen: variable index out of range");
    Poly p(std::move(r));
    fmpq_mpoly_gen(p.p_, static_cast<slong>(var), p.ctx());
    return p;
}

Poly Poly::constant(RingPtr r, const Rational& c) {
    Poly p(std::move(r));
    fmpq_mpoly_set_fmpq(p.p_, c.get(), p.ctx());
    return p;
}

Rational Poly::term_coeff(std::size_t i) const {
    Rational c;
    fmpq_mpoly_get_term_coeff_fmpq(c.get_mut(), p_, static_cast<slong>(i), ctx());
    return c;
}

std::vector<unsigned long> Poly::term_exponents(std::size_t i) const {
    std::vector<unsigned long> e(static_cast<std::size_t>(ctx()->zctx->minfo->nvars));
    fmpq_mpoly_get_term_exp_ui(e.data(), p_, static_cast<slong>(i), ctx());
    e.resize(ring_->size());
    return e;
}

namespace {

std::vector<const char*> c_names(const Ring& r) {
    std::vector<const char*> v;
    for (const auto& n : r.names()) v.push_back(n.c_str());
    if (v.empty()) v.push_back("_");
    return v;
}

}  // namespace

std::string Poly::to_string() const {
    auto names = c_names(*ring_);
    char* s = fmpq_mpoly_get_str_pretty(p_, names.data(), ctx());
    std::string out(s);
    flint_free(s);
    return out;
}

Poly& Poly::operator+=(const Poly& o) {
    require_same_ring(*this, o, "pgi::add");
    fmpq_mpoly_add(p_, p_, o.p_, ctx());
    ring_->budget().account("a sum", length());
    return *this;
}
Poly& Poly::operator-=(const Poly& o) {
    require_same_ring(*this, o, "pgi::sub");
    fmpq_mpoly_sub(p_, p_, o.p_, ctx());
    ring_->budget().account("a difference", length());
    return *this;
}
Poly& Poly::operator*=(const Rational& c) {
    fmpq_mpoly_scalar_mul_fmpq(p_, p_, c.get(), ctx());
    ring_->budget().account("a multiple", length());
    return *this;
}

bool operator==(const Poly& a, const Poly& b) {
    require_same_ring(a, b, "pgi::equal");
    return fmpq_mpoly_equal(a.get(), b.get(), a.ctx());
}
Poly operator+(const Poly& a, const Poly& b) { Poly r(a); r += b; return r; }
Poly operator-(const Poly& a, const Poly& b) { Poly r(a); r -= b; return r; }
Poly operator-(const Poly& a) {
    Poly r(a.ring());
    fmpq_mpoly_neg(r.get_mut(), a.get(), a.ctx());
    return accounted(std::move(r), "a negation");
}
Poly operator*(const Poly& a, const Poly& b) {
    require_same_ring(a, b, "pgi::mul");
    const std::size_t la = a.length(), lb = b.length();
    // NOTE: most products of the exact phase are small; estimating them cost as much as forming them, and
    // a product of at most small_product terms (and at most max_terms) cannot outgrow the budget by much
    // before its result is accounted.
    constexpr double small_product = 1024;
    const double at_most = static_cast<double>(la) * static_cast<double>(lb);
    if (at_most > std::min(small_product, static_cast<double>(a.ring()->max_terms()))) {
        const double d = degree(a) + degree(b);
        const double terms = std::min(at_most, monomials_up_to(a.ring()->size(), d));
        const double bits = coefficient_bits(a) + coefficient_bits(b) + std::log2(static_cast<double>(std::min(la, lb)) + 1);
        a.ring()->budget().reserve(terms, bytes_per_term(a.ring()->size(), d, bits),
                                   [&] { return "a product of a " + terms_text(la) + " and a " + terms_text(lb) + " polynomial"; });
    }
    Poly r(a.ring());
    fmpq_mpoly_mul(r.get_mut(), a.get(), b.get(), a.ctx());
    return accounted(std::move(r), "a product");
}
Poly operator*(const Rational& c, const Poly& a) { Poly r(a); r *= c; return r; }

Poly sum(std::vector<Poly> pieces, const RingPtr& ring) {
    std::erase_if(pieces, [](const Poly& p) { return p.is_zero(); });
    if (pieces.empty()) return Poly(ring);
    if (pieces.size() == 1) return std::move(pieces.front());
    const fmpz_mpoly_ctx_struct* zctx = ring->ctx()->zctx;
    Rational common(1);  // its numerator: the lcm D of the contents' denominators
    fmpz* D = fmpq_numref(common.get_mut());
    for (const Poly& p : pieces) {
        require_same_ring(p, pieces.front(), "pgi::sum");
        fmpz_lcm(D, D, fmpq_denref(p.get()->content));
    }
    Rational scale;
    for (Poly& p : pieces) {  // p = content * Z  ->  content = 1, Z scaled by content * D (an integer)
        fmpq* c = p.get_mut()->content;
        fmpz_divexact(fmpq_numref(scale.get_mut()), D, fmpq_denref(c));
        fmpz_mul(fmpq_numref(scale.get_mut()), fmpq_numref(scale.get_mut()), fmpq_numref(c));
        if (!fmpz_is_one(fmpq_numref(scale.get_mut())))
            fmpz_mpoly_scalar_mul_fmpz(p.get_mut()->zpoly, p.get()->zpoly, fmpq_numref(scale.get_mut()), zctx);
        fmpq_one(c);
    }
    while (pieces.size() > 1) {  // in pairs: each term is copied O(log count) times
        std::size_t kept = 0;
        for (std::size_t i = 0; i < pieces.size(); i += 2, ++kept) {
            if (i + 1 < pieces.size())
                fmpz_mpoly_add(pieces[i].get_mut()->zpoly, pieces[i].get()->zpoly, pieces[i + 1].get()->zpoly, zctx);
            if (kept != i) pieces[kept] = std::move(pieces[i]);
        }
        pieces.erase(pieces.begin() + static_cast<std::ptrdiff_t>(kept), pieces.end());
    }
    Poly r = std::move(pieces.front());
    fmpz_one(fmpq_numref(r.get_mut()->content));
    fmpz_set(fmpq_denref(r.get_mut()->content), D);
    fmpq_mpoly_reduce(r.get_mut(), r.ctx());  // the canonical content, once
    return accounted(std::move(r), "a sum");
}

Poly pow(const Poly& f, unsigned long k) {
    // f^k has at most binomial(length + k - 1, k) terms (multisets of k terms of f) and at most the
    // monomials of degree k deg f; its coefficients at most k times as many bits, plus k log2(length).
    const double l = static_cast<double>(f.length()), kk = static_cast<double>(k), d = kk * degree(f);
    const double terms = f.length() == 0 ? 1 : std::min(monomials_up_to(f.length() - 1, kk), monomials_up_to(f.ring()->size(), d));
    const double bits = kk * (coefficient_bits(f) + std::log2(l + 1));
    f.ring()->budget().reserve(terms, bytes_per_term(f.ring()->size(), d, bits), [&] {
        return "the power " + std::to_string(k) + " of a " + terms_text(f.length()) + " polynomial";
    });
    Poly r(f.ring());
    if (!fmpq_mpoly_pow_ui(r.get_mut(), f.get(), k, f.ctx()))
        throw std::overflow_error("pgi::pow: exponent overflow raising a " + std::to_string(f.length()) +
                                  "-term polynomial to the power " + std::to_string(k));
    return accounted(std::move(r), "a power");
}

Poly derivative(const Poly& f, std::size_t var) {
    if (var >= f.ring()->size()) throw std::out_of_range("pgi::derivative: variable index out of range");
    Poly r(f.ring());
    fmpq_mpoly_derivative(r.get_mut(), f.get(), static_cast<slong>(var), f.ctx());
    // FLINT sizes the result for every term of f: give back what the derivative does not hold, or the n
    // partial derivatives of a polynomial of O(n) terms keep O(n^2) of memory (the gradient of S_dt)
    fmpq_mpoly_realloc(r.get_mut(), static_cast<slong>(r.length()), f.ctx());
    return accounted(std::move(r), "a derivative");
}

Poly substitute(const Poly& f, const std::vector<Poly>& images) {
    if (images.size() != f.ring()->size())
        throw std::invalid_argument("pgi::substitute: need one image per variable");
    std::vector<fmpq_mpoly_struct*> c;
    for (const auto& g : images) {
        require_same_ring(f, g, "pgi::substitute");
        c.push_back(const_cast<fmpq_mpoly_struct*>(g.get()));  // FLINT's signature lacks const; it only reads
    }
    if (c.empty()) return f;
    // each term of f becomes a product of at most deg f images: at most length(f) L^deg f terms (L the
    // longest image), at most the monomials of degree deg f times the highest image degree
    double longest = 1, image_degree = 0, bits = 0;
    for (const auto& g : images) {
        longest = std::max(longest, static_cast<double>(g.length()));
        image_degree = std::max(image_degree, degree(g));
        bits = std::max(bits, coefficient_bits(g));
    }
    const double d = degree(f) * image_degree;
    const double terms = std::min(static_cast<double>(f.length()) * std::pow(longest, degree(f)), monomials_up_to(f.ring()->size(), d));
    f.ring()->budget().reserve(terms, bytes_per_term(f.ring()->size(), d, coefficient_bits(f) + degree(f) * (bits + std::log2(longest + 1))),
                               [&] { return "a substitution into a " + terms_text(f.length()) + " polynomial"; });
    Poly r(f.ring());
    if (!fmpq_mpoly_compose_fmpq_mpoly(r.get_mut(), f.get(), c.data(), f.ctx(), f.ctx()))
        throw std::overflow_error("pgi::substitute: exponent overflow");
    return accounted(std::move(r), "a substitution");
}

Poly sum_powers(const std::vector<Poly>& c, const Rational& t, unsigned long first) {
    if (c.empty()) throw std::invalid_argument("pgi::sum_powers: no coefficients");
    Poly sum(c.front().ring());
    Rational power(1);
    for (unsigned long j = 0; j < first; ++j) power = power * t;
    for (const auto& cj : c) {
        sum += power * cj;
        power = power * t;
    }
    return sum;
}

double evaluate(const Poly& f, std::span<const double> point) {
    if (point.size() != f.ring()->size()) throw std::invalid_argument("pgi::evaluate: point has the wrong size");
    double sum = 0;
    for (std::size_t i = 0; i < f.length(); ++i) {
        auto e = f.term_exponents(i);
        double m = f.term_coeff(i).to_double();
        for (std::size_t v = 0; v < e.size(); ++v)
            for (unsigned long k = 0; k < e[v]; ++k) m *= point[v];
        sum += m;
    }
    return sum;
}

unsigned long masked_degree(std::span<const unsigned long> exps, const VarMask& mask) {
    unsigned long d = 0;
    for (std::size_t v = 0; v < exps.size() && v < mask.size(); ++v)
        if (mask[v]) d += exps[v];
    return d;
}

namespace {

// The terms of f whose masked degree satisfies keep(d), in order (so the result stays canonical).
template <class Keep>
Poly filter_terms(const Poly& f, const VarMask& mask, Keep keep) {
    Poly r(f.ring());
    fmpq_t c;
    fmpq_init(c);
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    for (slong i = 0; i < static_cast<slong>(f.length()); ++i) {
        fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), i, f.ctx());
        if (!keep(masked_degree(std::span<const unsigned long>(e.data(), f.ring()->size()), mask))) continue;
        fmpq_mpoly_get_term_coeff_fmpq(c, f.get(), i, f.ctx());
        fmpq_mpoly_push_term_fmpq_ui(r.get_mut(), c, e.data(), f.ctx());
    }
    fmpq_clear(c);
    fmpq_mpoly_reduce(r.get_mut(), f.ctx());  // terms arrive sorted; reduce normalises content
    return accounted(std::move(r), "a truncation");
}

}  // namespace

Poly homogeneous_part(const Poly& f, const VarMask& mask, unsigned long m) {
    return filter_terms(f, mask, [m](unsigned long d) { return d == m; });
}

Poly truncate(const Poly& f, const VarMask& mask, unsigned long max_degree) {
    return filter_terms(f, mask, [max_degree](unsigned long d) { return d <= max_degree; });
}

long masked_degree(const Poly& f, const VarMask& mask) {
    long best = -1;
    for (std::size_t i = 0; i < f.length(); ++i) {
        auto e = f.term_exponents(i);
        best = std::max(best, static_cast<long>(masked_degree(e, mask)));
    }
    return best;
}

}  // namespace pgi

namespace pgi {

Poly rename_variables(const Poly& f, RingPtr target, const std::vector<long>& var_map) {
    if (var_map.size() != f.ring()->size()) throw std::invalid_argument("pgi::rename_variables: need one target per variable");
    for (long v : var_map)
        if (v < 0 || static_cast<std::size_t>(v) >= target->size())
            throw std::out_of_range("pgi::rename_variables: target variable out of range");
    Poly r(std::move(target));
    std::vector<slong> c(var_map.begin(), var_map.end());
    if (c.empty()) c.push_back(0);
    fmpq_mpoly_compose_fmpq_mpoly_gen(r.get_mut(), f.get(), c.data(), f.ctx(), r.ctx());
    return accounted(std::move(r), "a change of ring");
}

}  // namespace pgi
