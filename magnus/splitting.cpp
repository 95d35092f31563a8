#include "magnus/splitting.hpp"

#include <cmath>
#include <stdexcept>

namespace pgi {

namespace {

// Q(w) = Q[w]/(w^d - sum_i rel[i] w^i): d = 1 with no relation is Q itself. An element is a vector of d
// coefficients on 1, w, ..., w^{d-1}.
struct NumberField {
    std::size_t d = 1;
    std::vector<Rational> relation;  // w^d = sum_i relation[i] w^i
    // w^e on the basis, for e < 2d - 1 (products of two basis elements)
    std::vector<Rational> power(std::size_t e) const {
        std::vector<Rational> v(d);
        if (e < d) {
            v[e] = Rational(1);
            return v;
        }
        const auto lower = power(e - 1);  // multiply by w: shift, then replace w^d
        for (std::size_t i = 0; i + 1 < d; ++i) v[i + 1] = lower[i];
        for (std::size_t i = 0; i < d; ++i) v[i] = v[i] + lower[d - 1] * relation[i];
        return v;
    }
    std::vector<Rational> multiply(const std::vector<Rational>& a, const std::vector<Rational>& b) const {
        std::vector<Rational> r(d);
        for (std::size_t i = 0; i < d; ++i)
            for (std::size_t j = 0; j < d; ++j) {
                const auto wij = power(i + j);
                for (std::size_t c = 0; c < d; ++c) r[c] = r[c] + a[i] * b[j] * wij[c];
            }
        return r;
    }
};

// w = 1/(2 - 2^{1/3}) satisfies 2w^3 + (1 - 2w)^3 = 0, i.e. w^3 = 2w^2 - w + 1/6
NumberField yoshida_field() {
    return {3, {Rational(1, 6), Rational(-1), Rational(2)}};
}

// A Lie algebra element over the field: one e-series per basis element.
using Element = std::vector<Series>;

Element zero_element(const NumberField& F, const RingPtr& ring, std::size_t N) {
    return Element(F.d, Series(ring, N));
}

// X(c e): the coefficient of e^m multiplied by c^m, c in the field
Element rescaled(const NumberField& F, const Element& X, const std::vector<Rational>& c) {
    const std::size_t N = X[0].order();
    Element r = zero_element(F, X[0].ring(), N);
    std::vector<Rational> cm = F.power(0);
    for (std::size_t m = 0; m < N; ++m) {
        for (std::size_t i = 0; i < F.d; ++i)
            for (std::size_t j = 0; j < F.d; ++j) {
                const auto w = F.multiply(F.power(i), cm);  // w^i c^m on the basis, applied to X's w^i part
                if (!w[j].is_zero()) r[j][m] += w[j] * X[i][m];
            }
        cm = F.multiply(cm, c);
    }
    return r;
}

// The s-polynomial form of the Magnus equation: Z(s) = sum_j s^j Z[j], dZ/ds = sum_i B_i/i! ad_Z^i Y,
// Z(0) = X. ad_Z raises the order in e by one (X, Y = O(e)), so the e^m coefficient of the right-hand
// side needs Z through e^{m-1} only: solved order by order. The terms T_i = ad_Z^i Y are kept between
// orders, so that order m adds only the e^m coefficient of each, T_i[m] = sum_{a+b=m} {Z[a], T_{i-1}[b]}.
Element compose(const PoissonStructure& pi, const NumberField& F, const Element& X, const Element& Y, std::size_t N) {
    for (const Element* E : {&X, &Y})
        for (const auto& s : *E)
            if (s.order() != N || !s[0].is_zero())
                throw std::invalid_argument("compose_flows: the series must be O(e) and of the requested order");
    const RingPtr& ring = pi.phase_space().ring();
    // Graded[j][c][k]: the s^j w^c e^k coefficient; the s-degree of an e^k coefficient is at most k
    using Graded = std::vector<std::vector<std::vector<Poly>>>;
    const Graded zero(N, std::vector<std::vector<Poly>>(F.d, std::vector<Poly>(N, Poly(ring))));
    Graded Z = zero;
    for (std::size_t c = 0; c < F.d; ++c)
        for (std::size_t k = 0; k < N; ++k) Z[0][c][k] = X[c][k];
    std::vector<Graded> T(N > 1 ? N - 1 : 1, zero);  // T[i] = ad_Z^i Y
    for (std::size_t c = 0; c < F.d; ++c)
        for (std::size_t k = 0; k < N; ++k) T[0][0][c][k] = Y[c][k];
    std::vector<std::vector<Rational>> w;  // w^e on the basis, e < 2d - 1
    for (std::size_t e = 0; e + 1 < 2 * F.d; ++e) w.push_back(F.power(e));
    for (std::size_t m = 1; m < N; ++m) {
        for (std::size_t i = 1; i < m; ++i)
            for (std::size_t a = 1; a < m; ++a) {  // Z[.][a] with T_{i-1}[.][m - a]
                const std::size_t b = m - a;
                for (std::size_t ja = 0; ja <= a; ++ja)
                    for (std::size_t jb = 0; jb <= b && ja + jb < N; ++jb)
                        for (std::size_t ca = 0; ca < F.d; ++ca) {
                            const Poly& za = Z[ja][ca][a];
                            if (za.is_zero()) continue;
                            for (std::size_t cb = 0; cb < F.d; ++cb) {
                                const Poly& tb = T[i - 1][jb][cb][b];
                                if (tb.is_zero()) continue;
                                const Poly br = pi.bracket(za, tb);
                                for (std::size_t c = 0; c < F.d; ++c)
                                    if (!w[ca + cb][c].is_zero()) T[i][ja + jb][c][m] += w[ca + cb][c] * br;
                            }
                        }
            }
        // the right-hand side's e^m coefficient, integrated in s: Z[j + 1] += rhs[j]/(j + 1)
        for (std::size_t j = 0; j + 1 < N; ++j)
            for (std::size_t c = 0; c < F.d; ++c) {
                Poly rhs = T[0][j][c][m];
                for (std::size_t i = 1; i < m; ++i) {
                    const Rational coefficient = bernoulli(i) * inverse_factorial(i);
                    if (!coefficient.is_zero() && !T[i][j][c][m].is_zero()) rhs += coefficient * T[i][j][c][m];
                }
                if (!rhs.is_zero()) Z[j + 1][c][m] += Rational(1, static_cast<unsigned long>(j + 1)) * rhs;
            }
    }
    Element total = zero_element(F, ring, N);  // Z(1)
    for (std::size_t j = 0; j < N; ++j)
        for (std::size_t c = 0; c < F.d; ++c)
            for (std::size_t k = 0; k < N; ++k) total[c][k] += Z[j][c][k];
    return total;
}

// the flow of A for time c dt as an element: c A e
Element flow_of(const NumberField& F, const Poly& A, const std::vector<Rational>& c, std::size_t N) {
    Element r = zero_element(F, A.ring(), N);
    for (std::size_t i = 0; i < F.d; ++i) r[i][1] = c[i] * A;
    return r;
}

std::vector<Rational> scalar(const NumberField& F, const Rational& q) {
    std::vector<Rational> v(F.d);
    v[0] = q;
    return v;
}

}  // namespace

SplittingMethod parse_splitting_method(const std::string& name) {
    if (name == "lie-trotter") return SplittingMethod::lie_trotter;
    if (name == "strang") return SplittingMethod::strang;
    if (name == "yoshida") return SplittingMethod::yoshida;
    throw std::invalid_argument("unknown splitting method '" + name + "' (choose lie-trotter, strang or yoshida)");
}

std::string to_string(SplittingMethod method) {
    switch (method) {
        case SplittingMethod::lie_trotter:
            return "lie-trotter";
        case SplittingMethod::strang:
            return "strang";
        case SplittingMethod::yoshida:
            return "yoshida";
    }
    return "?";
}

std::size_t method_order(SplittingMethod method) {
    return method == SplittingMethod::lie_trotter ? 1 : method == SplittingMethod::strang ? 2 : 4;
}

double yoshida_weight() {
    return 1.0 / (2.0 - std::cbrt(2.0));
}

Series compose_flows(const PoissonStructure& pi, const Series& X, const Series& Y, std::size_t N) {
    return compose(pi, NumberField{}, Element{X}, Element{Y}, N).front();
}

SplittingModified splitting_modified_hamiltonian(const PoissonStructure& pi, const Poly& A, const Poly& B,
                                                 SplittingMethod method, std::size_t m) {
    const std::size_t N = m + 2;  // Z through e^{m+1}: Htilde = Z/dt through dt^m
    const NumberField F = method == SplittingMethod::yoshida ? yoshida_field() : NumberField{};
    auto strang = [&] {
        const Element half = flow_of(F, A, scalar(F, Rational(1, 2)), N);
        return compose(pi, F, compose(pi, F, half, flow_of(F, B, scalar(F, Rational(1)), N), N), half, N);
    };
    Element Z;
    if (method == SplittingMethod::lie_trotter)
        Z = compose(pi, F, flow_of(F, A, scalar(F, Rational(1)), N), flow_of(F, B, scalar(F, Rational(1)), N), N);
    else if (method == SplittingMethod::strang)
        Z = strang();
    else {
        const Element S = strang();
        const std::vector<Rational> w{Rational(0), Rational(1), Rational(0)},
            w0{Rational(1), Rational(-2), Rational(0)};
        const Element outer = rescaled(F, S, w);
        Z = compose(pi, F, compose(pi, F, outer, rescaled(F, S, w0), N), outer, N);
    }
    SplittingModified r{method, {}};
    for (std::size_t j = 0; j <= m; ++j) {
        r.H.emplace_back();
        for (std::size_t c = 0; c < F.d; ++c) r.H.back().push_back(Z[c][j + 1]);
    }
    return r;
}

double SplittingModified::evaluate(const std::vector<double>& x, double dt) const {
    const double w = yoshida_weight();
    std::vector<double> point(x);
    if (!H.empty()) point.resize(H[0][0].ring()->size(), 0.0);  // the ring's other variables (momenta p) at 0
    double sum = 0, dtj = 1;
    for (const auto& Hj : H) {
        double wc = 1, term = 0;
        for (const auto& P : Hj) {
            if (!P.is_zero()) term += wc * pgi::evaluate(P, point);
            wc *= w;
        }
        sum += dtj * term;
        dtj *= dt;
    }
    return sum;
}

}  // namespace pgi
