#include "series/poly.hpp"

#include <cctype>
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

}  // namespace

Ring::Ring(std::vector<std::string> names, std::size_t max_terms) : names_(std::move(names)), max_terms_(max_terms) {
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
    return *this;
}
Poly& Poly::operator-=(const Poly& o) {
    require_same_ring(*this, o, "pgi::sub");
    fmpq_mpoly_sub(p_, p_, o.p_, ctx());
    return *this;
}
Poly& Poly::operator*=(const Rational& c) {
    fmpq_mpoly_scalar_mul_fmpq(p_, p_, c.get(), ctx());
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
    return r;
}
Poly operator*(const Poly& a, const Poly& b) {
    require_same_ring(a, b, "pgi::mul");
    const std::size_t la = a.length(), lb = b.length(), limit = a.ring()->max_terms();
    if (la != 0 && lb > limit / la)
        throw ResourceLimitError("a product of a " + std::to_string(la) + "-term and a " + std::to_string(lb) +
                                 "-term polynomial could reach " + std::to_string(la * lb) + " terms, above the limit of " +
                                 std::to_string(limit) + " (raise it with --max-terms)");
    Poly r(a.ring());
    fmpq_mpoly_mul(r.get_mut(), a.get(), b.get(), a.ctx());
    return r;
}
Poly operator*(const Rational& c, const Poly& a) { Poly r(a); r *= c; return r; }

Poly pow(const Poly& f, unsigned long k) {
    Poly r(f.ring());
    if (!fmpq_mpoly_pow_ui(r.get_mut(), f.get(), k, f.ctx()))
        throw std::overflow_error("pgi::pow: exponent overflow raising a " + std::to_string(f.length()) +
                                  "-term polynomial to the power " + std::to_string(k));
    return r;
}

Poly derivative(const Poly& f, std::size_t var) {
    if (var >= f.ring()->size()) throw std::out_of_range("pgi::derivative: variable index out of range");
    Poly r(f.ring());
    fmpq_mpoly_derivative(r.get_mut(), f.get(), static_cast<slong>(var), f.ctx());
    return r;
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
    Poly r(f.ring());
    if (!fmpq_mpoly_compose_fmpq_mpoly(r.get_mut(), f.get(), c.data(), f.ctx(), f.ctx()))
        throw std::overflow_error("pgi::substitute: exponent overflow");
    return r;
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
    return r;
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
    return r;
}

}  // namespace pgi
