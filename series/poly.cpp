#include "series/poly.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numeric>
#include <optional>
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

std::string terms_text(std::size_t n) {
    return std::to_string(n) + "-term";
}

using Variables = std::vector<std::uint32_t>;
constexpr std::size_t not_kept = static_cast<std::size_t>(-1);

// r = f with local variable j of f moved to local variable position[j] of r (not_kept: j is absent from every
// term; two variables moved to one multiply), r zero and stored over r's variables. The ring's order
// restricted to a set of variables is the order on them, so when the positions increase (monotone) the terms
// keep their order: their exponent words are repacked, no sort. Otherwise they are sorted and like terms
// combined.
void place_terms(Poly& r, const Poly& f, const std::vector<std::size_t>& position, bool monotone) {
    const fmpz_mpoly_struct* z = f.get()->zpoly;
    fmpq_set(r.get_mut()->content, f.get()->content);
    if (z->length == 0) return;
    const mpoly_ctx_struct* from = f.ctx()->zctx->minfo;
    const mpoly_ctx_struct* to = r.ctx()->zctx->minfo;
    fmpz_mpoly_struct* w = r.get_mut()->zpoly;
    if (monotone && z->bits <= FLINT_BITS) {
        std::vector<ulong> ef(static_cast<std::size_t>(from->nvars)), er(static_cast<std::size_t>(to->nvars), 0);
        // The bits of r's fields: as few as its terms need, with FLINT's zero top bit (the room its arithmetic
        // detects overflow in; mpoly_exp_bits_required_ui). FLINT rounds a small context's up to fill its
        // words (32 bits a field for one variable), which over thousands of variables would cost 4x the bytes.
        const std::size_t nf = mpoly_words_per_exp(z->bits, from);
        mpoly_get_monomial_ui(ef.data(), z->exps, z->bits, from);
        const ulong degree = std::accumulate(ef.begin(), ef.end(), ulong(0));  // the first term's is the highest
        const flint_bitcnt_t bits =
            mpoly_fix_bits(std::max<flint_bitcnt_t>(MPOLY_MIN_BITS, 1 + FLINT_BIT_COUNT(degree)), to);
        const std::size_t nr = mpoly_words_per_exp(bits, to);
        fmpz_mpoly_fit_length_reset_bits(w, z->length, bits, r.ctx()->zctx);
        for (slong t = 0; t < z->length; ++t) {
            mpoly_get_monomial_ui(ef.data(), z->exps + nf * std::size_t(t), z->bits, from);
            for (std::size_t j = 0; j < position.size(); ++j)  // a constant's context has one variable, unused
                if (position[j] != not_kept) er[position[j]] = ef[j];
            mpoly_set_monomial_ui(w->exps + nr * std::size_t(t), er.data(), bits, to);
            fmpz_set(w->coeffs + t, z->coeffs + t);
        }
        _fmpz_mpoly_set_length(w, z->length, r.ctx()->zctx);
        return;
    }
    // any exponents, any map: term by term through FLINT's own packing
    const std::size_t nf = static_cast<std::size_t>(from->nvars), nr = static_cast<std::size_t>(to->nvars);
    std::vector<fmpz> ef(nf), er(nr);
    std::vector<fmpz*> pf(nf), pr(nr);
    for (std::size_t j = 0; j < nf; ++j) fmpz_init(&ef[j]), pf[j] = &ef[j];
    for (std::size_t j = 0; j < nr; ++j) fmpz_init(&er[j]), pr[j] = &er[j];
    for (slong t = 0; t < z->length; ++t) {
        fmpz_mpoly_get_term_exp_fmpz(pf.data(), z, t, f.ctx()->zctx);
        for (std::size_t j = 0; j < position.size(); ++j)
            if (position[j] != not_kept) fmpz_zero(&er[position[j]]);
        for (std::size_t j = 0; j < position.size(); ++j)
            if (position[j] != not_kept) fmpz_add(&er[position[j]], &er[position[j]], &ef[j]);
        fmpz_mpoly_push_term_fmpz_fmpz(w, z->coeffs + t, pr.data(), r.ctx()->zctx);
    }
    for (auto& e : ef) fmpz_clear(&e);
    for (auto& e : er) fmpz_clear(&e);
    if (!monotone) {
        fmpz_mpoly_sort_terms(w, r.ctx()->zctx);
        fmpz_mpoly_combine_like_terms(w, r.ctx()->zctx);
        fmpq_mpoly_reduce(r.get_mut(), r.ctx());
    }
}

// f stored over vars, a superset of f.variables() (local storage).
Poly stored_over(const Poly& f, const Variables& vars) {
    const auto fv = f.variables();
    std::vector<std::size_t> position(fv.size());
    for (std::size_t j = 0, k = 0; j < fv.size(); ++j) {
        while (vars[k] != fv[j]) ++k;
        position[j] = k;
    }
    Poly r(f.ring(), vars);
    place_terms(r, f, position, true);
    return r;
}

// Whether two polynomials are stored over the same variables (dense storage: the ring's own list, at once).
bool same_variables(const Poly& f, const Poly& g) {
    const auto a = f.variables(), b = g.variables();
    return a.data() == b.data() || std::equal(a.begin(), a.end(), b.begin(), b.end());
}

// The union of the polynomials' variables, or nothing when they are all stored over the same ones (always so
// for dense storage).
std::optional<Variables> common_variables(std::span<const Poly* const> fs) {
    if (std::all_of(fs.begin(), fs.end(), [&](const Poly* f) { return same_variables(*f, *fs.front()); }))
        return std::nullopt;
    Variables u;
    for (const Poly* f : fs) u.insert(u.end(), f->variables().begin(), f->variables().end());
    std::sort(u.begin(), u.end());
    u.erase(std::unique(u.begin(), u.end()), u.end());
    return u;
}

// The operands of a binary operation over their common variables: themselves, or copies stored over the union.
struct Aligned {
    Aligned(const Poly& a, const Poly& b) {
        const Poly* both[] = {&a, &b};
        if (auto u = common_variables(both)) {
            if (a.variables().size() != u->size()) a_.emplace(stored_over(a, *u));
            if (b.variables().size() != u->size()) b_.emplace(stored_over(b, *u));
        }
        pa = a_ ? &*a_ : &a;
        pb = b_ ? &*b_ : &b;
    }
    const Poly* pa;
    const Poly* pb;

private:
    std::optional<Poly> a_, b_;
};

// self = op(self, o) (FLINT's add or sub) over the variables of both: self is moved to them in place, o copied
// only when it holds fewer; then what cancelled is given back.
template <class Op>
Poly& combine(Poly& self, const Poly& o, Op op, const char* where, std::string_view what) {
    require_same_ring(self, o, where);
    const Poly* b = &o;
    std::optional<Poly> moved;
    const Poly* both[] = {&self, &o};
    if (auto u = common_variables(both)) {
        if (self.variables().size() != u->size()) self = stored_over(self, *u);
        if (o.variables().size() != u->size()) b = &moved.emplace(stored_over(o, *u));
    }
    op(self.get_mut(), self.get(), b->get(), self.ctx());
    self.drop_unused_variables();
    self.ring()->budget().account(what, self.length());
    return self;
}

// Zero, stored over f's variables.
Poly zero_like(const Poly& f) {
    if (!f.ring()->local_storage()) return Poly(f.ring());
    return Poly(f.ring(), Variables(f.variables().begin(), f.variables().end()));
}

}  // namespace

Ring::Ring(std::vector<std::string> names, std::size_t max_terms, PolyStorage storage)
    : Ring(std::move(names), std::make_shared<const Budget>(BudgetLimits{.max_terms = max_terms}), storage) {}

void Ring::ContextDelete::operator()(fmpq_mpoly_ctx_struct* c) const {
    fmpq_mpoly_ctx_clear(c);
    delete c;
}

Ring::~Ring() {
    fmpq_mpoly_ctx_clear(ctx_);
}

Ring::Ring(std::vector<std::string> names, std::shared_ptr<const Budget> budget, PolyStorage storage)
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
    all_variables_.resize(names_.size());
    std::iota(all_variables_.begin(), all_variables_.end(), 0u);
    if (storage == PolyStorage::local || (storage == PolyStorage::automatic && names_.size() >= local_storage_from)) {
        // NOTE: one small context per count of variables (about 600 bytes each), made once: the polynomials
        // share them and no lock is needed
        for (std::size_t m = 1; m <= std::max<std::size_t>(names_.size(), 1); ++m) {
            auto* c = new fmpq_mpoly_ctx_struct;
            fmpq_mpoly_ctx_init(c, static_cast<slong>(m), ORD_DEGREVLEX);
            local_ctx_.emplace_back(c);
        }
    }
}

long Ring::index_of(std::string_view name) const {
    for (std::size_t i = 0; i < names_.size(); ++i)
        if (names_[i] == name) return static_cast<long>(i);
    return -1;
}

Poly::Poly(RingPtr r, std::vector<std::uint32_t> over) : ring_(std::move(r)) {
    if (ring_->local_storage()) vars_ = std::move(over);
    fmpq_mpoly_init(p_, ctx());
}

void Poly::drop_unused_variables() {
    if (!ring_->local_storage() || vars_.empty()) return;
    if (is_zero()) {
        *this = Poly(ring_);
        return;
    }
    std::vector<int> used(vars_.size());
    fmpq_mpoly_used_vars(used.data(), p_, ctx());
    if (std::all_of(used.begin(), used.end(), [](int u) { return u != 0; })) return;
    std::vector<std::size_t> position(vars_.size(), not_kept);
    Variables kept;
    for (std::size_t j = 0; j < vars_.size(); ++j)
        if (used[j]) position[j] = kept.size(), kept.push_back(vars_[j]);
    Poly r(ring_, std::move(kept));
    place_terms(r, *this, position, true);
    *this = std::move(r);
}

Poly Poly::gen(RingPtr r, std::size_t var) {
    if (var >= r->size()) throw std::out_of_range("pgi::Poly::gen: variable index out of range");
    Poly p(r, Variables{static_cast<std::uint32_t>(var)});
    fmpq_mpoly_gen(p.p_, r->local_storage() ? 0 : static_cast<slong>(var), p.ctx());
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
    std::vector<unsigned long> local(static_cast<std::size_t>(ctx()->zctx->minfo->nvars));
    fmpq_mpoly_get_term_exp_ui(local.data(), p_, static_cast<slong>(i), ctx());
    std::vector<unsigned long> e(ring_->size(), 0);
    const auto vars = variables();
    for (std::size_t j = 0; j < vars.size(); ++j) e[vars[j]] = local[j];
    return e;
}

namespace {

std::vector<const char*> c_names(const Poly& f) {
    std::vector<const char*> v;
    for (std::uint32_t var : f.variables()) v.push_back(f.ring()->names()[var].c_str());
    if (v.empty()) v.push_back("_");
    return v;
}

}  // namespace

std::string Poly::to_string() const {
    auto names = c_names(*this);
    char* s = fmpq_mpoly_get_str_pretty(p_, names.data(), ctx());
    std::string out(s);
    flint_free(s);
    return out;
}

Poly& Poly::operator+=(const Poly& o) {
    return combine(*this, o, fmpq_mpoly_add, "pgi::add", "a sum");
}
Poly& Poly::operator-=(const Poly& o) {
    return combine(*this, o, fmpq_mpoly_sub, "pgi::sub", "a difference");
}
Poly& Poly::operator*=(const Rational& c) {
    fmpq_mpoly_scalar_mul_fmpq(p_, p_, c.get(), ctx());
    drop_unused_variables();  // only when c = 0
    ring_->budget().account("a multiple", length());
    return *this;
}

bool operator==(const Poly& a, const Poly& b) {
    require_same_ring(a, b, "pgi::equal");
    return same_variables(a, b) &&
           fmpq_mpoly_equal(a.get(), b.get(), a.ctx());  // local storage: both hold exactly these
}
Poly operator+(const Poly& a, const Poly& b) {
    Poly r(a);
    r += b;
    return r;
}
Poly operator-(const Poly& a, const Poly& b) {
    Poly r(a);
    r -= b;
    return r;
}
Poly operator-(const Poly& a) {
    Poly r = zero_like(a);
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
        const std::size_t nvars = std::min(a.variables().size() + b.variables().size(), a.ring()->size());
        const double terms = std::min(at_most, monomials_up_to(nvars, d));
        const double bits =
            coefficient_bits(a) + coefficient_bits(b) + std::log2(static_cast<double>(std::min(la, lb)) + 1);
        a.ring()->budget().reserve(terms, bytes_per_term(nvars, d, bits), [&] {
            return "a product of a " + terms_text(la) + " and a " + terms_text(lb) + " polynomial";
        });
    }
    if (a.is_zero() || b.is_zero()) return accounted(Poly(a.ring()), "a product");
    Aligned ab(a, b);
    Poly r = zero_like(*ab.pa);  // over Q, a product of non-zero polynomials holds every variable of either
    fmpq_mpoly_mul(r.get_mut(), ab.pa->get(), ab.pb->get(), r.ctx());
    return accounted(std::move(r), "a product");
}
Poly operator*(const Rational& c, const Poly& a) {
    Poly r(a);
    r *= c;
    return r;
}

Poly sum(std::vector<Poly> pieces, const RingPtr& ring) {
    std::erase_if(pieces, [](const Poly& p) { return p.is_zero(); });
    if (pieces.empty()) return Poly(ring);
    if (pieces.size() == 1) return std::move(pieces.front());
    for (const Poly& p : pieces) require_same_ring(p, pieces.front(), "pgi::sum");
    Rational common(1);  // its numerator: the lcm D of the contents' denominators
    fmpz* D = fmpq_numref(common.get_mut());
    for (const Poly& p : pieces) fmpz_lcm(D, D, fmpq_denref(p.get()->content));
    Rational scale;
    for (Poly& p : pieces) {  // p = content * Z  ->  content = 1, Z scaled by content * D (an integer)
        fmpq* c = p.get_mut()->content;
        fmpz_divexact(fmpq_numref(scale.get_mut()), D, fmpq_denref(c));
        fmpz_mul(fmpq_numref(scale.get_mut()), fmpq_numref(scale.get_mut()), fmpq_numref(c));
        if (!fmpz_is_one(fmpq_numref(scale.get_mut())))
            fmpz_mpoly_scalar_mul_fmpz(p.get_mut()->zpoly, p.get()->zpoly, fmpq_numref(scale.get_mut()), p.ctx()->zctx);
        fmpq_one(c);
    }
    // In pairs: each term is copied O(log count) times. Local storage: a pair is moved to the variables of both
    // only when it is added, and the pieces are added in the order of their variables, so that neighbours (of a
    // sparse scene) meet first: their sums stay small, and like terms (which hold the same variables) cancel at
    // the lower levels, not in the last sum over every variable (FLINT sizes a sum for both operands' terms).
    if (ring->local_storage())
        std::stable_sort(pieces.begin(), pieces.end(), [](const Poly& a, const Poly& b) {
            const auto va = a.variables(), vb = b.variables();
            return std::lexicographical_compare(va.begin(), va.end(), vb.begin(), vb.end());
        });
    while (pieces.size() > 1) {
        std::size_t kept = 0;
        for (std::size_t i = 0; i < pieces.size(); i += 2, ++kept) {
            if (i + 1 < pieces.size()) {
                Aligned ab(pieces[i], pieces[i + 1]);
                Poly r = zero_like(*ab.pa);
                fmpq_one(r.get_mut()->content);
                fmpz_mpoly_add(r.get_mut()->zpoly, ab.pa->get()->zpoly, ab.pb->get()->zpoly, r.ctx()->zctx);
                pieces[i] = std::move(r);
            }
            if (kept != i) pieces[kept] = std::move(pieces[i]);
        }
        pieces.erase(pieces.begin() + static_cast<std::ptrdiff_t>(kept), pieces.end());
    }
    Poly r = std::move(pieces.front());
    fmpz_one(fmpq_numref(r.get_mut()->content));
    fmpz_set(fmpq_denref(r.get_mut()->content), D);
    fmpq_mpoly_reduce(r.get_mut(), r.ctx());  // the canonical content, once
    r.drop_unused_variables();
    return accounted(std::move(r), "a sum");
}

Poly pow(const Poly& f, unsigned long k) {
    // f^k has at most binomial(length + k - 1, k) terms (multisets of k terms of f) and at most the
    // monomials of degree k deg f; its coefficients at most k times as many bits, plus k log2(length).
    const double l = static_cast<double>(f.length()), kk = static_cast<double>(k), d = kk * degree(f);
    const std::size_t nvars = f.variables().size();
    const double terms = f.length() == 0 ? 1 : std::min(monomials_up_to(f.length() - 1, kk), monomials_up_to(nvars, d));
    const double bits = kk * (coefficient_bits(f) + std::log2(l + 1));
    f.ring()->budget().reserve(terms, bytes_per_term(nvars, d, bits), [&] {
        return "the power " + std::to_string(k) + " of a " + terms_text(f.length()) + " polynomial";
    });
    if (k == 0) return accounted(Poly::constant(f.ring(), 1), "a power");
    Poly r = zero_like(f);
    if (!fmpq_mpoly_pow_ui(r.get_mut(), f.get(), k, f.ctx()))
        throw std::overflow_error("pgi::pow: exponent overflow raising a " + std::to_string(f.length()) +
                                  "-term polynomial to the power " + std::to_string(k));
    return accounted(std::move(r), "a power");
}

Poly derivative(const Poly& f, std::size_t var) {
    if (var >= f.ring()->size()) throw std::out_of_range("pgi::derivative: variable index out of range");
    const auto vars = f.variables();
    const auto at = std::lower_bound(vars.begin(), vars.end(), static_cast<std::uint32_t>(var));
    if (at == vars.end() || *at != var) return accounted(Poly(f.ring()), "a derivative");
    Poly r = zero_like(f);
    fmpq_mpoly_derivative(r.get_mut(), f.get(), static_cast<slong>(at - vars.begin()), f.ctx());
    // FLINT sizes the result for every term of f: give back what the derivative does not hold, or the n
    // partial derivatives of a polynomial of O(n) terms keep O(n^2) of memory (the gradient of S_dt)
    fmpq_mpoly_realloc(r.get_mut(), static_cast<slong>(r.length()), f.ctx());
    r.drop_unused_variables();
    return accounted(std::move(r), "a derivative");
}

Poly substitute(const Poly& f, const std::vector<Poly>& images) {
    if (images.size() != f.ring()->size()) throw std::invalid_argument("pgi::substitute: need one image per variable");
    for (const auto& g : images) require_same_ring(f, g, "pgi::substitute");
    if (images.empty()) return f;
    // only the images of the variables f is stored over take part (local storage: those it holds)
    std::vector<const Poly*> used;
    for (std::uint32_t v : f.variables()) used.push_back(&images[v]);
    // each term of f becomes a product of at most deg f images: at most length(f) L^deg f terms (L the
    // longest image), at most the monomials of degree deg f times the highest image degree
    double longest = 1, image_degree = 0, bits = 0;
    for (const Poly* g : used) {
        longest = std::max(longest, static_cast<double>(g->length()));
        image_degree = std::max(image_degree, degree(*g));
        bits = std::max(bits, coefficient_bits(*g));
    }
    const auto common = used.empty() ? std::nullopt : common_variables(used);
    const std::size_t nvars = common ? common->size() : used.empty() ? 1 : used.front()->variables().size();
    const double d = degree(f) * image_degree;
    const double terms =
        std::min(static_cast<double>(f.length()) * std::pow(longest, degree(f)), monomials_up_to(nvars, d));
    f.ring()->budget().reserve(
        terms, bytes_per_term(nvars, d, coefficient_bits(f) + degree(f) * (bits + std::log2(longest + 1))),
        [&] { return "a substitution into a " + terms_text(f.length()) + " polynomial"; });
    if (used.empty()) return f;  // a constant
    std::vector<Poly> stored;    // the images over their common variables, where they differ
    if (common) {
        stored.reserve(used.size());
        for (const Poly*& g : used)
            if (g->variables().size() != common->size()) g = &stored.emplace_back(stored_over(*g, *common));
    }
    std::vector<fmpq_mpoly_struct*> c;
    for (const Poly* g : used)
        c.push_back(const_cast<fmpq_mpoly_struct*>(g->get()));  // FLINT's signature lacks const; it only reads
    Poly r = zero_like(*used.front());
    if (!fmpq_mpoly_compose_fmpq_mpoly(r.get_mut(), f.get(), c.data(), f.ctx(), r.ctx()))
        throw std::overflow_error("pgi::substitute: exponent overflow");
    r.drop_unused_variables();
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
    const auto vars = f.variables();
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    double sum = 0;
    for (std::size_t i = 0; i < f.length(); ++i) {
        fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), static_cast<slong>(i), f.ctx());
        double m = f.term_coeff(i).to_double();
        for (std::size_t j = 0; j < vars.size(); ++j)
            for (unsigned long k = 0; k < e[j]; ++k) m *= point[vars[j]];
        sum += m;
    }
    return sum;
}

double term_size(const Poly& f, std::span<const double> x) {
    double s = 0;
    for (std::size_t t = 0; t < f.length(); ++t) {
        double c = std::abs(f.term_coeff(t).to_double());
        const auto e = f.term_exponents(t);
        for (std::size_t v = 0; v < x.size() && v < e.size() && c != 0; ++v)
            if (e[v] != 0) c = x[v] == 0 ? 0.0 : c * std::pow(std::abs(x[v]), double(e[v]));  // (0, not 0 inf)
        s += c;
    }
    return s;
}

std::vector<std::size_t> used_variables(const Poly& f) {
    const auto vars = f.variables();
    std::vector<int> used(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars),
                          1);  // a ring of no names has a context of one
    if (!f.ring()->local_storage()) fmpq_mpoly_used_vars(used.data(), f.get(), f.ctx());
    std::vector<std::size_t> held;
    for (std::size_t j = 0; j < vars.size(); ++j)
        if (used[j]) held.push_back(vars[j]);
    return held;
}

unsigned long masked_degree(std::span<const unsigned long> exps, const VarMask& mask) {
    unsigned long d = 0;
    for (std::size_t v = 0; v < exps.size() && v < mask.size(); ++v)
        if (mask[v]) d += exps[v];
    return d;
}

namespace {

// The degree in the masked variables of each term of f, in order.
std::vector<unsigned long> masked_degrees(const Poly& f, const VarMask& mask) {
    const auto vars = f.variables();
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    std::vector<unsigned long> degrees(f.length());
    for (std::size_t i = 0; i < f.length(); ++i) {
        fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), static_cast<slong>(i), f.ctx());
        for (std::size_t j = 0; j < vars.size(); ++j)
            if (vars[j] < mask.size() && mask[vars[j]]) degrees[i] += e[j];
    }
    return degrees;
}

// The terms of f whose masked degree satisfies keep(d), in order (so the result stays canonical).
template <class Keep>
Poly filter_terms(const Poly& f, const VarMask& mask, Keep keep) {
    Poly r = zero_like(f);
    fmpq_t c;
    fmpq_init(c);
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    const auto degrees = masked_degrees(f, mask);
    for (slong i = 0; i < static_cast<slong>(f.length()); ++i) {
        if (!keep(degrees[std::size_t(i)])) continue;
        fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), i, f.ctx());
        fmpq_mpoly_get_term_coeff_fmpq(c, f.get(), i, f.ctx());
        fmpq_mpoly_push_term_fmpq_ui(r.get_mut(), c, e.data(), r.ctx());
    }
    fmpq_clear(c);
    fmpq_mpoly_reduce(r.get_mut(), r.ctx());  // terms arrive sorted; reduce normalises content
    r.drop_unused_variables();
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
    for (unsigned long d : masked_degrees(f, mask)) best = std::max(best, static_cast<long>(d));
    return best;
}

}  // namespace pgi

namespace pgi {

Poly rename_variables(const Poly& f, RingPtr target, const std::vector<long>& var_map) {
    if (var_map.size() != f.ring()->size())
        throw std::invalid_argument("pgi::rename_variables: need one target per variable");
    for (long v : var_map)
        if (v < 0 || static_cast<std::size_t>(v) >= target->size())
            throw std::out_of_range("pgi::rename_variables: target variable out of range");
    const auto vars = f.variables();
    std::vector<std::uint32_t> to;  // the target variables of f's
    for (std::uint32_t v : vars) to.push_back(static_cast<std::uint32_t>(var_map[v]));
    std::vector<std::uint32_t> over(to);
    std::sort(over.begin(), over.end());
    over.erase(std::unique(over.begin(), over.end()), over.end());
    Poly r(target, target->local_storage() ? over : std::vector<std::uint32_t>{});
    const auto rvars = r.variables();
    std::vector<std::size_t> position(vars.size());
    for (std::size_t j = 0; j < vars.size(); ++j)
        position[j] = static_cast<std::size_t>(std::lower_bound(rvars.begin(), rvars.end(), to[j]) - rvars.begin());
    // in order and one to one, the terms keep their order (the ring's order restricted to the variables)
    place_terms(r, f, position, std::is_sorted(to.begin(), to.end()) && over.size() == to.size());
    r.drop_unused_variables();
    return accounted(std::move(r), "a change of ring");
}

}  // namespace pgi
