#include "magnus/polynomial_in.hpp"

#include <flint/fmpq_mat.h>

#include <map>
#include <stdexcept>

namespace pgi {

namespace {

// the exponent vectors a with sum a_i d_i <= D, in lexicographic order
void products(const std::vector<long>& d, long D, std::vector<unsigned long>& a, std::size_t i,
              std::vector<std::vector<unsigned long>>& out, std::size_t limit) {
    if (out.size() > limit) return;
    if (i == d.size()) {
        out.push_back(a);
        return;
    }
    for (long used = 0; used <= D; used += d[i]) {
        products(d, D - used, a, i + 1, out, limit);
        ++a[i];
    }
    a[i] = 0;
}

// RAII for fmpq_mat
struct Matrix {
    fmpq_mat_t m;
    Matrix(slong r, slong c) { fmpq_mat_init(m, r, c); }
    ~Matrix() { fmpq_mat_clear(m); }
    Matrix(const Matrix&) = delete;
    Matrix& operator=(const Matrix&) = delete;
};

}  // namespace

std::optional<Poly> as_polynomial_in(const Poly& P, const std::vector<Poly>& G, const std::vector<std::string>& names,
                                     std::size_t max_products, std::size_t max_monomials) {
    if (names.size() != G.size()) throw std::invalid_argument("as_polynomial_in: one name per generator");
    RingPtr target = make_ring(names);
    if (P.is_zero()) return Poly(target);
    std::vector<long> d;
    for (const auto& g : G) {
        if (g.total_degree() < 1) throw std::invalid_argument("as_polynomial_in: a generator is constant");
        d.push_back(g.total_degree());
    }
    std::vector<std::vector<unsigned long>> exps;
    std::vector<unsigned long> a(G.size(), 0);
    products(d, P.total_degree(), a, 0, exps, max_products);
    if (exps.size() > max_products) return std::nullopt;
    // the columns G^a, and the rows: every monomial of P and of the products
    std::vector<Poly> columns;
    std::map<std::vector<unsigned long>, slong> rows;
    auto index_terms = [&](const Poly& f) {
        for (std::size_t t = 0; t < f.length(); ++t) rows.emplace(f.term_exponents(t), slong(rows.size()));
    };
    for (const auto& e : exps) {
        Poly c = Poly::constant(P.ring(), Rational(1));
        for (std::size_t i = 0; i < G.size(); ++i)
            if (e[i] > 0) c = c * pow(G[i], e[i]);
        index_terms(c);
        columns.push_back(std::move(c));
        if (rows.size() > max_monomials) return std::nullopt;
    }
    index_terms(P);
    if (rows.size() > max_monomials) return std::nullopt;
    Matrix A(slong(rows.size()), slong(columns.size())), b(slong(rows.size()), 1), x(slong(columns.size()), 1);
    for (std::size_t j = 0; j < columns.size(); ++j)
        for (std::size_t t = 0; t < columns[j].length(); ++t)
            fmpq_set(fmpq_mat_entry(A.m, rows.at(columns[j].term_exponents(t)), slong(j)),
                     columns[j].term_coeff(t).get());
    for (std::size_t t = 0; t < P.length(); ++t)
        fmpq_set(fmpq_mat_entry(b.m, rows.at(P.term_exponents(t)), 0), P.term_coeff(t).get());
    if (!fmpq_mat_can_solve(x.m, A.m, b.m)) return std::nullopt;
    Poly Q(target);
    for (std::size_t j = 0; j < exps.size(); ++j) {
        Rational c;
        fmpq_set(c.get_mut(), fmpq_mat_entry(x.m, slong(j), 0));
        if (c.is_zero()) continue;
        Poly term = Poly::constant(target, c);
        for (std::size_t i = 0; i < G.size(); ++i)
            if (exps[j][i] > 0) term = term * pow(Poly::gen(target, i), exps[j][i]);
        Q += term;
    }
    return Q;
}

}  // namespace pgi
