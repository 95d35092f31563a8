#include "series/series.hpp"

#include <map>
#include <stdexcept>

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

// Products prod_v images[v]^{e_v} over the substituted variables, memoised by exponent vector:
// each new monomial costs one truncated product, from a monomial of one degree less.
class MonomialProducts {
public:
    MonomialProducts(const RingPtr& r, const std::vector<std::optional<Series>>& images, std::size_t N)
        : images_(images), one_(Series::constant(Poly::constant(r, 1), N)) {}

    const Series& operator()(const std::vector<unsigned long>& e) {
        if (auto it = cache_.find(e); it != cache_.end()) return it->second;
        std::size_t v = 0;
        while (v < e.size() && e[v] == 0) ++v;
        if (v == e.size()) return one_;
        std::vector<unsigned long> lower = e;
        --lower[v];
        Series product = mul_trunc((*this)(lower), *images_[v]);
        return cache_.emplace(e, std::move(product)).first->second;
    }

private:
    const std::vector<std::optional<Series>>& images_;
    Series one_;
    std::map<std::vector<unsigned long>, Series> cache_;
};

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
    MonomialProducts products(ring, images, N);
    for (const Poly& f : fs) {
        // f = sum_e c_e(kept variables) * prod_{v substituted} v^{e_v}: group the terms by e first.
        std::map<std::vector<unsigned long>, Poly> groups;
        for (std::size_t t = 0; t < f.length(); ++t) {
            auto e = f.term_exponents(t);
            Poly kept = Poly::constant(ring, f.term_coeff(t));
            for (std::size_t v = 0; v < nvars; ++v) {
                if (images[v]) continue;
                if (e[v] > 0) kept = kept * pow(Poly::gen(ring, v), e[v]);
                e[v] = 0;
            }
            groups.try_emplace(std::move(e), ring).first->second += kept;
        }
        Series result(ring, N);
        for (const auto& [e, kept] : groups) {
            const Series& product = products(e);
            for (std::size_t m = 0; m < N; ++m)
                if (!product[m].is_zero()) result[m] += kept * product[m];
        }
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
    std::vector<Series> v(u.size(), Series(ring, std::min<std::size_t>(N, 1)));
    for (std::size_t sweep = 1; sweep < N; ++sweep) {
        // v <- -u(id + v). v is exact through e^(sweep-1) and u = O(e), so this sweep is exact through
        // e^sweep: it needs order sweep + 1 only (computing every sweep to order N cost ~N times more).
        const std::size_t M = sweep + 1;
        std::vector<std::optional<Series>> images(ring->size());
        for (std::size_t i = 0; i < vars.size(); ++i) {
            Series image = Series::constant(Poly::gen(ring, vars[i]), M);
            for (std::size_t m = 0; m < v[i].order(); ++m) image[m] += v[i][m];
            images[vars[i]] = std::move(image);
        }
        v = compose(u, images, M);
        for (auto& s : v) s *= Rational(-1);
        if (enough && enough(v)) break;
    }
    return v;
}

}  // namespace pgi
