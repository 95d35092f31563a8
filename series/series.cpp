#include "series/series.hpp"

#include <cstdint>
#include <map>
#include <stdexcept>
#include <utility>

namespace pgi {

namespace {

void require_same_order(const Series& a, const Series& b, const char* where) {
    if (a.order() != b.order())
        throw std::invalid_argument(std::string(where) + ": truncation orders differ (" + std::to_string(a.order()) +
                                    " and " + std::to_string(b.order()) + ")");
}

}  // namespace

Series::Series(RingPtr r, std::size_t N) : ring_(std::move(r)), c_(N, Poly(ring_)) {}

Series Series::constant(const Poly& c, std::size_t N) {
    Series s(c.ring(), N);
    if (N > 0) s.c_[0] = c;
    return s;
}

Series Series::graded(const Poly& f, const VarMask& mask, std::size_t N) {
    Series s(f.ring(), N);
    for (std::size_t m = 0; m < N; ++m) s.c_[m] = homogeneous_part(f, mask, m);
    return s;
}

Poly Series::sum() const {
    Poly r(ring_);
    for (const auto& c : c_) r += c;
    return r;
}

Series Series::truncated(std::size_t N) const {
    if (N > order()) throw std::invalid_argument("pgi::Series::truncated: cannot raise the truncation order");
    Series s(ring_, N);
    for (std::size_t m = 0; m < N; ++m) s.c_[m] = c_[m];
    return s;
}

Series& Series::operator+=(const Series& o) {
    require_same_order(*this, o, "pgi::Series add");
    for (std::size_t m = 0; m < c_.size(); ++m) c_[m] += o.c_[m];
    return *this;
}
Series& Series::operator-=(const Series& o) {
    require_same_order(*this, o, "pgi::Series sub");
    for (std::size_t m = 0; m < c_.size(); ++m) c_[m] -= o.c_[m];
    return *this;
}
Series& Series::operator*=(const Rational& c) {
    for (auto& p : c_) p *= c;
    return *this;
}

bool operator==(const Series& a, const Series& b) {
    if (a.order() != b.order()) return false;
    for (std::size_t m = 0; m < a.order(); ++m)
        if (!(a[m] == b[m])) return false;
    return true;
}
Series operator+(const Series& a, const Series& b) { Series r(a); r += b; return r; }
Series operator-(const Series& a, const Series& b) { Series r(a); r -= b; return r; }
Series operator*(const Rational& c, const Series& a) { Series r(a); r *= c; return r; }

Series mul_trunc(const Series& a, const Series& b) {
    require_same_order(a, b, "pgi::mul_trunc");
    Series r(a.ring(), a.order());
    for (std::size_t i = 0; i < a.order(); ++i) {
        if (a[i].is_zero()) continue;
        for (std::size_t j = 0; i + j < a.order(); ++j)
            if (!b[j].is_zero()) r[i + j] += a[i] * b[j];
    }
    return r;
}

namespace {

// The exponents of the substituted variables in a monomial, as (variable, exponent > 0) by increasing variable:
// O(variables held), where a dense exponent vector costs O(ring size) (2n on a lattice of n sites) per monomial.
using SparseExponents = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

// Products prod_v images[v]^{e_v} over the substituted variables, memoised by exponent vector and computed
// coefficient by coefficient, on demand: coefficient d of a product from a monomial of one degree less,
// reading the images' coefficients through d only (so images may still be completed above d).
class MonomialProducts {
public:
    MonomialProducts(const RingPtr& r, const std::vector<std::optional<Series>>& images) : ring_(r), images_(images) {}

    // The coefficients 0..d of the product for e.
    const std::vector<Poly>& through(const SparseExponents& e, std::size_t d) {
        auto [it, fresh] = cache_.try_emplace(e);
        std::vector<Poly>& c = it->second;
        if (e.empty()) {  // the constant 1
            if (c.empty()) c.push_back(Poly::constant(ring_, 1));
            while (c.size() <= d) c.emplace_back(ring_);
            return c;
        }
        if (c.size() > d) return c;
        SparseExponents lower = e;
        if (--lower.front().second == 0) lower.erase(lower.begin());
        const std::vector<Poly>& low = through(lower, d);
        const Series& image = *images_[e.front().first];
        for (std::size_t k = c.size(); k <= d; ++k) {
            Poly r(ring_);
            for (std::size_t i = 0; i <= k; ++i)
                if (!low[i].is_zero() && !image[k - i].is_zero()) r += low[i] * image[k - i];
            c.push_back(std::move(r));
        }
        return c;
    }

private:
    RingPtr ring_;
    const std::vector<std::optional<Series>>& images_;
    std::map<SparseExponents, std::vector<Poly>> cache_;
};

// f = sum_e c_e(kept variables) * prod_{v substituted} v^{e_v}: the terms grouped by e.
std::map<SparseExponents, Poly> substitution_groups(const Poly& f, const std::vector<std::optional<Series>>& images) {
    const RingPtr& ring = f.ring();
    std::map<SparseExponents, Poly> groups;
    std::vector<ulong> e(static_cast<std::size_t>(f.ctx()->zctx->minfo->nvars));
    for (std::size_t t = 0; t < f.length(); ++t) {
        fmpq_mpoly_get_term_exp_ui(e.data(), f.get(), static_cast<slong>(t), f.ctx());
        Poly kept = Poly::constant(ring, f.term_coeff(t));
        SparseExponents key;
        for (std::size_t v = 0; v < ring->size(); ++v) {
            if (e[v] == 0) continue;
            if (images[v])
                key.emplace_back(static_cast<std::uint32_t>(v), static_cast<std::uint32_t>(e[v]));
            else
                kept = kept * pow(Poly::gen(ring, v), e[v]);
        }
        groups.try_emplace(std::move(key), ring).first->second += kept;
    }
    return groups;
}

// The sum of the pieces, added in pairs: each term is copied O(log count) times, where adding them one by one
// into a growing result copies it count times (quadratic for H = x_1 + ... + x_n composed with a lattice's images).
Poly balanced_sum(std::vector<Poly> pieces, const RingPtr& ring) {
    if (pieces.empty()) return Poly(ring);
    while (pieces.size() > 1) {
        std::size_t kept = 0;
        for (std::size_t i = 0; i < pieces.size(); i += 2, ++kept) {
            if (i + 1 < pieces.size()) pieces[i] += pieces[i + 1];  // in place: no third polynomial
            if (kept != i) pieces[kept] = std::move(pieces[i]);
        }
        pieces.erase(pieces.begin() + std::ptrdiff_t(kept), pieces.end());
    }
    return std::move(pieces.front());
}

void check_images(std::size_t nvars, const std::vector<std::optional<Series>>& images, std::size_t N) {
    if (images.size() != nvars) throw std::invalid_argument("pgi::compose: need one (optional) image per variable");
    for (const auto& im : images)
        if (im && im->order() != N) throw std::invalid_argument("pgi::compose: an image has the wrong truncation order");
}

}  // namespace

std::vector<Series> compose(const std::vector<Poly>& fs, const std::vector<std::optional<Series>>& images, std::size_t N) {
    std::vector<Series> out;
    if (fs.empty()) return out;
    const RingPtr& ring = fs.front().ring();
    const std::size_t nvars = ring->size();
    check_images(nvars, images, N);
    MonomialProducts products(ring, images);
    for (const Poly& f : fs) {
        Series result(ring, N);
        std::vector<std::vector<Poly>> pieces(N);
        if (N > 0)
            for (const auto& [e, kept] : substitution_groups(f, images)) {
                const auto& product = products.through(e, N - 1);
                for (std::size_t m = 0; m < N; ++m)
                    if (!product[m].is_zero()) pieces[m].push_back(kept * product[m]);
            }
        for (std::size_t m = 0; m < N; ++m) result[m] = balanced_sum(std::move(pieces[m]), ring);
        out.push_back(std::move(result));
    }
    return out;
}

Series compose(const Poly& f, const std::vector<std::optional<Series>>& images, std::size_t N) {
    return std::move(compose(std::vector<Poly>{f}, images, N).front());
}

std::vector<Series> compose(const std::vector<Series>& fs, const std::vector<std::optional<Series>>& images, std::size_t N) {
    std::vector<Series> out;
    if (fs.empty()) return out;
    const RingPtr& ring = fs.front().ring();
    // all coefficients at once, so they share the products of the images
    std::vector<Poly> coefficients;
    for (const auto& f : fs)
        for (std::size_t m = 0; m < std::min(f.order(), N); ++m) coefficients.push_back(f[m]);
    const auto composed = compose(coefficients, images, N);
    std::size_t next = 0;
    for (const auto& f : fs) {
        Series r(ring, N);
        for (std::size_t m = 0; m < std::min(f.order(), N); ++m, ++next)
            for (std::size_t d = 0; m + d < N; ++d) r[m + d] += composed[next][d];
        out.push_back(std::move(r));
    }
    return out;
}

std::vector<Series> inverse_near_identity(const std::vector<Series>& u, const std::vector<std::size_t>& vars, std::size_t N,
                                          const std::function<bool(const std::vector<Series>&)>& enough) {
    if (u.size() != vars.size()) throw std::invalid_argument("pgi::inverse_near_identity: one displacement per variable");
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
    std::vector<std::vector<std::map<SparseExponents, Poly>>> groups(u.size());  // [i][m]: u_i's e^m part
    for (std::size_t i = 0; i < u.size(); ++i)
        for (std::size_t m = 0; m < N; ++m) groups[i].push_back(substitution_groups(u[i][m], images));
    MonomialProducts products(ring, images);
    std::vector<Series> v(u.size(), Series(ring, std::min<std::size_t>(N, 1)));
    for (std::size_t s = 1; s < N; ++s) {
        std::vector<Poly> next(u.size(), Poly(ring));
        for (std::size_t i = 0; i < u.size(); ++i) {
            for (std::size_t m = 1; m <= s; ++m)
                for (const auto& [e, kept] : groups[i][m]) {
                    const Poly& product = products.through(e, s - m)[s - m];
                    if (!product.is_zero()) next[i] -= kept * product;
                }
        }
        for (std::size_t i = 0; i < u.size(); ++i) {
            (*images[vars[i]])[s] = next[i];
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
