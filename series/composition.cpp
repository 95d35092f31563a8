#include "series/composition.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace pgi {

namespace {

// f = sum_e c_e(kept variables) * prod_{v substituted} v^{e_v}: the terms grouped by e. Every term of f shares
// its content, so a group is that content times f's integer terms with their substituted exponents zeroed,
// pushed in f's order and reduced once at the end (not rebuilt by sums nor rescaled at each term). Local
// storage: each group is stored over the variables its own terms keep, not over all of f's (a G_d of a lattice
// holds every site's variables and has a group per monomial in the momenta).
std::map<SparseExponents, Poly> substitution_groups(const Poly& f, const std::vector<std::optional<Series>>& images) {
    const RingPtr& ring = f.ring();
    const fmpz_mpoly_ctx_struct* zctx = f.ctx()->zctx;
    const auto vars = f.variables();  // f's exponent vectors run over these
    struct Term {
        std::size_t index;
        SparseExponents kept;  // (position in vars, exponent) of the variables not substituted
    };
    std::map<SparseExponents, std::vector<Term>> terms;
    std::vector<ulong> e(static_cast<std::size_t>(zctx->minfo->nvars));
    for (std::size_t t = 0; t < f.length(); ++t) {
        fmpz_mpoly_get_term_exp_ui(e.data(), f.get()->zpoly, static_cast<slong>(t), zctx);
        SparseExponents key, kept;
        for (std::size_t j = 0; j < vars.size(); ++j)
            if (e[j] != 0) (images[vars[j]] ? key.emplace_back(vars[j], e[j]) : kept.emplace_back(j, e[j]));
        terms[std::move(key)].push_back(Term{t, std::move(kept)});
    }
    // A group's terms are f's with one monomial (its key) divided out, pushed in f's order: a monomial order is
    // compatible with multiplication (a > b iff a c > b c), so they are already sorted, and distinct; restricted
    // to fewer variables the order is the same. FLINT's sort would cost a pass per exponent bit.
    std::map<SparseExponents, Poly> groups;
    std::vector<std::size_t> position(vars.size());
    for (auto& [key, group] : terms) {
        std::vector<std::uint32_t> over;
        if (ring->local_storage()) {
            for (const Term& t : group)
                for (const auto& [j, ej] : t.kept) over.push_back(j);
            std::sort(over.begin(), over.end());
            over.erase(std::unique(over.begin(), over.end()), over.end());
            for (std::size_t k = 0; k < over.size(); ++k) position[over[k]] = k, over[k] = vars[over[k]];
        } else {
            std::iota(position.begin(), position.end(), std::size_t(0));
        }
        Poly kept(ring, std::move(over));
        fmpq_set(kept.get_mut()->content, f.get()->content);
        std::vector<ulong> k(static_cast<std::size_t>(kept.ctx()->zctx->minfo->nvars));
        for (const Term& t : group) {
            std::fill(k.begin(), k.end(), 0);
            for (const auto& [j, ej] : t.kept) k[position[j]] = ej;
            fmpz_mpoly_push_term_fmpz_ui(kept.get_mut()->zpoly, f.get()->zpoly->coeffs + t.index, k.data(),
                                         kept.ctx()->zctx);
        }
        fmpq_mpoly_reduce(kept.get_mut(), kept.ctx());
        groups.emplace(key, std::move(kept));
    }
    return groups;
}

// The coefficients 0..N-1 of each series, one after the other (a temporary for ComposeByOrder to group).
std::vector<Poly> coefficients(const std::vector<Series>& fs, std::size_t N) {
    std::vector<Poly> out;
    for (const auto& f : fs)
        for (std::size_t m = 0; m < std::min(f.order(), N); ++m) out.push_back(f[m]);
    return out;
}

void check_images(std::size_t nvars, const std::vector<std::optional<Series>>& images, std::size_t N) {
    if (images.size() != nvars) throw std::invalid_argument("pgi::compose: need one (optional) image per variable");
    for (const auto& im : images)
        if (im && im->order() != N)
            throw std::invalid_argument("pgi::compose: an image has the wrong truncation order");
}

}  // namespace

ComposeByOrder::ComposeByOrder(RingPtr ring, std::vector<std::optional<Series>> images, std::size_t N)
    : ring_(std::move(ring)), N_(N), images_(std::move(images)) {
    one_.emplace(Poly::constant(ring_, 1)), zero_.emplace(ring_);
    check_images(ring_->size(), images_, N);
    products_.emplace_back();  // the empty product
    product_of_.emplace(SparseExponents{}, 0);
}

ComposeByOrder::ComposeByOrder(const std::vector<Poly>& fs, std::vector<std::optional<Series>> images, std::size_t N)
    : N_(N) {
    if (fs.empty()) return;
    *this = ComposeByOrder(fs.front().ring(), std::move(images), N);
    for (const Poly& f : fs) append(f);
}

std::size_t ComposeByOrder::append(const Poly& f) {
    if (f.ring() != ring_) throw std::invalid_argument("pgi::compose: the polynomials belong to different rings");
    auto& groups = groups_.emplace_back();
    for (auto& [e, kept] : substitution_groups(f, images_)) {
        std::optional<Rational> scalar;
        if (fmpq_mpoly_is_fmpq(kept.get(), kept.ctx()))
            fmpq_mpoly_get_fmpq(scalar.emplace().get_mut(), kept.get(), kept.ctx());
        groups.push_back(Group{product_index(e), std::move(kept), std::move(scalar)});
    }
    return groups_.size() - 1;
}

std::uint32_t ComposeByOrder::product_index(const SparseExponents& e) {
    // e, e less one of its first variable, ... down to a product formed before (the empty one at worst), then each
    // formed from the one below it: a loop, since the chain is as long as e's degree
    std::vector<SparseExponents> chain;
    auto found = product_of_.find(e);
    for (SparseExponents lower = e; found == product_of_.end(); found = product_of_.find(lower)) {
        chain.push_back(lower);
        if (--lower.front().second == 0) lower.erase(lower.begin());
    }
    std::uint32_t index = found->second;
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
        products_.push_back(Product{it->front().first, index, {}});
        index = product_of_[*it] = static_cast<std::uint32_t>(products_.size() - 1);
    }
    return index;
}

void ComposeByOrder::set_image(std::size_t v, std::size_t m, Poly c) {
    if (v >= images_.size() || !images_[v] || m >= N_)
        throw std::invalid_argument("pgi::ComposeByOrder::set_image: variable " + std::to_string(v) +
                                    " has no image of order " + std::to_string(m + 1));
    if (static_cast<long>(m) <= composed_through_)
        throw std::logic_error("pgi::ComposeByOrder::set_image: order " + std::to_string(m) +
                               " of an image was already read");
    (*images_[v])[m] = std::move(c);
}

const Poly& ComposeByOrder::product_coefficient(std::uint32_t p, std::size_t m) {
    if (p == 0) return m == 0 ? *one_ : *zero_;
    // the products below p (each one factor less) whose coefficients through m are not formed yet, formed from the
    // lowest up, each once: a loop, since the chain is as long as the product's degree
    std::vector<std::uint32_t> chain;
    for (std::uint32_t q = p; products_[q].lower != 0 && products_[q].c.size() <= m; q = products_[q].lower)
        chain.push_back(q);
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) extend_product(*it, m);
    const Product& product = products_[p];
    return product.lower == 0 ? (*images_[product.factor])[m] : product.c[m];
}

// Product q's coefficients through m, from its lower product's (formed through m, or an image) and its factor's image.
void ComposeByOrder::extend_product(std::uint32_t q, std::size_t m) {
    Product& product = products_[q];
    const Series& image = *images_[product.factor];
    const Product& lower = products_[product.lower];
    const Series* lower_image = lower.lower == 0 ? &*images_[lower.factor] : nullptr;
    std::vector<Poly>& c = product.c;
    c.reserve(N_);
    std::vector<Poly> terms;
    for (std::size_t k = c.size(); k <= m; ++k) {
        terms.clear();
        for (std::size_t i = 0; i <= k; ++i) {
            const Poly& low = lower_image ? (*lower_image)[i] : lower.c[i];
            if (!low.is_zero() && !image[k - i].is_zero()) terms.push_back(low * image[k - i]);
        }
        c.push_back(terms.empty() ? Poly(ring_) : sum(std::move(terms), ring_));
    }
}

Poly ComposeByOrder::coefficient(std::size_t i, std::size_t m) {
    if (i >= groups_.size() || m >= N_)
        throw std::out_of_range("pgi::ComposeByOrder::coefficient: no order " + std::to_string(m) + " of polynomial " +
                                std::to_string(i));
    composed_through_ = std::max(composed_through_, static_cast<long>(m));
    std::vector<Poly> pieces;
    pieces.reserve(groups_[i].size());
    for (const Group& g : groups_[i]) {
        const Poly& product = product_coefficient(g.product, m);
        if (!product.is_zero()) pieces.push_back(g.scalar ? *g.scalar * product : g.kept * product);
    }
    return sum(std::move(pieces), ring_);
}

std::vector<Series> compose(const std::vector<Poly>& fs, const std::vector<std::optional<Series>>& images,
                            std::size_t N) {
    std::vector<Series> out;
    if (fs.empty()) return out;
    ComposeByOrder composed(fs, images, N);
    for (std::size_t i = 0; i < fs.size(); ++i) {
        Series result(fs[i].ring(), N);
        for (std::size_t m = 0; m < N; ++m) result[m] = composed.coefficient(i, m);
        out.push_back(std::move(result));
    }
    return out;
}

Series compose(const Poly& f, const std::vector<std::optional<Series>>& images, std::size_t N) {
    return std::move(compose(std::vector<Poly>{f}, images, N).front());
}

std::vector<Series> compose(const std::vector<Series>& fs, const std::vector<std::optional<Series>>& images,
                            std::size_t N) {
    std::vector<Series> out;
    if (fs.empty()) return out;
    const RingPtr& ring = fs.front().ring();
    const auto composed = compose(coefficients(fs, N), images, N);  // all at once: they share the image products
    std::size_t next = 0;
    for (const auto& f : fs) {
        Series r(ring, N);
        for (std::size_t m = 0; m < std::min(f.order(), N); ++m, ++next)
            for (std::size_t d = 0; m + d < N; ++d) r[m + d] += composed[next][d];
        out.push_back(std::move(r));
    }
    return out;
}

std::vector<Series> inverse_near_identity(const std::vector<Series>& u, const std::vector<std::size_t>& vars,
                                          std::size_t N,
                                          const std::function<bool(const std::vector<Series>&)>& enough) {
    if (u.size() != vars.size())
        throw std::invalid_argument("pgi::inverse_near_identity: one displacement per variable");
    if (u.empty()) return {};
    const RingPtr& ring = u.front().ring();
    for (const auto& ui : u)
        if (ui.order() != N || (N > 0 && !ui[0].is_zero()))
            throw std::invalid_argument("pgi::inverse_near_identity: every displacement must be O(e) and of order N");
    // v = -u(id + v) order by order: coefficient s of u_m(id + v) (m >= 1) reads the images' coefficients
    // through s - m < s only, which are final, so each product coefficient is computed once (the sweeps
    // v <- -u(id + v) recomputed every lower order at every sweep, ~N times the work).
    std::vector<std::optional<Series>> images(ring->size());
    for (std::size_t i = 0; i < vars.size(); ++i) images[vars[i]] = Series::constant(Poly::gen(ring, vars[i]), N);
    ComposeByOrder u_after_v(coefficients(u, N), std::move(images), N);  // u_i's e^m part at i * N + m
    std::vector<Series> v(u.size(), Series(ring, std::min<std::size_t>(N, 1)));
    for (std::size_t s = 1; s < N; ++s) {
        std::vector<Poly> next(u.size(), Poly(ring));
        for (std::size_t i = 0; i < u.size(); ++i)
            for (std::size_t m = 1; m <= s; ++m) next[i] -= u_after_v.coefficient(i * N + m, s - m);
        for (std::size_t i = 0; i < u.size(); ++i) {
            u_after_v.set_image(vars[i], s, next[i]);
            Series grown(ring, s + 1);
            for (std::size_t d = 0; d < s; ++d) grown[d] = std::move(v[i][d]);
            grown[s] = std::move(next[i]);
            v[i] = std::move(grown);
        }
        if (enough && enough(v)) break;
    }
    return v;
}

}  // namespace pgi
