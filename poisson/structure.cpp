#include "poisson/structure.hpp"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace pgi {

std::string to_string(StructureClass c) {
    switch (c) {
        case StructureClass::constant: return "constant";
        case StructureClass::linear: return "linear";
        case StructureClass::log_canonical: return "log-canonical";
        case StructureClass::general: return "general";
    }
    return "?";
}

namespace {

bool all_entries(const std::vector<std::vector<Poly>>& pi, auto pred) {
    for (std::size_t i = 0; i < pi.size(); ++i)
        for (std::size_t j = 0; j < pi.size(); ++j)
            if (!pi[i][j].is_zero() && !pred(i, j, pi[i][j])) return false;
    return true;
}

// x_i x_j times a rational, nothing else.
bool is_log_canonical_entry(std::size_t i, std::size_t j, const Poly& f) {
    if (f.length() != 1) return false;
    auto e = f.term_exponents(0);
    for (std::size_t v = 0; v < e.size(); ++v)
        if (e[v] != ((v == i || v == j) ? 1u : 0u)) return false;
    return true;
}

StructureClass classify(const PhaseSpace& M, const std::vector<std::vector<Poly>>& pi) {
    const VarMask all(M.ring()->size(), true);
    if (all_entries(pi, [](auto, auto, const Poly& f) { return f.total_degree() == 0; })) return StructureClass::constant;
    if (all_entries(pi, [&](auto, auto, const Poly& f) { return homogeneous_part(f, all, 1) == f; }))
        return StructureClass::linear;
    if (all_entries(pi, is_log_canonical_entry)) return StructureClass::log_canonical;
    return StructureClass::general;
}

}  // namespace

PoissonStructure::PoissonStructure(PhaseSpace M, std::vector<std::vector<Poly>> pi)
    : M_(std::move(M)), pi_(std::move(pi)), class_(StructureClass::general) {
    const std::size_t n = M_.dim();
    if (pi_.size() != n) throw std::invalid_argument("pi must be a " + std::to_string(n) + " x " + std::to_string(n) + " matrix");
    for (const auto& row : pi_)
        if (row.size() != n) throw std::invalid_argument("pi must be a " + std::to_string(n) + " x " + std::to_string(n) + " matrix");
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i; j < n; ++j)
            if ((!pi_[i][j].is_zero() || !pi_[j][i].is_zero()) && !(pi_[i][j] + pi_[j][i]).is_zero())
                throw std::invalid_argument("pi is not skew-symmetric at (" + M_.coordinates()[i] + ", " +
                                            M_.coordinates()[j] + "): {" + M_.coordinates()[i] + "," +
                                            M_.coordinates()[j] + "} = " + pi_[i][j].to_string() + " but {" +
                                            M_.coordinates()[j] + "," + M_.coordinates()[i] + "} = " +
                                            pi_[j][i].to_string());
    class_ = classify(M_, pi_);
    rows_.resize(n);
    std::vector<int> used(M_.ring()->size());
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            if (pi_[i][j].is_zero()) continue;
            fmpq_mpoly_used_vars(used.data(), pi_[i][j].get(), M_.ring()->ctx());
            Entry e{j, {}};
            for (std::size_t l = 0; l < n; ++l)
                if (used[M_.x(l)]) e.vars.push_back(l);
            rows_[i].push_back(std::move(e));
        }
}

const std::vector<std::size_t>& PoissonStructure::entry_vars(std::size_t i, std::size_t j) const {
    static const std::vector<std::size_t> none;
    auto it = std::lower_bound(rows_[i].begin(), rows_[i].end(), j, [](const Entry& e, std::size_t v) { return e.j < v; });
    return it != rows_[i].end() && it->j == j ? it->vars : none;
}

std::vector<std::size_t> PoissonStructure::row_support(std::size_t i) const {
    std::vector<std::size_t> js;
    for (const auto& e : rows_[i]) js.push_back(e.j);
    return js;
}

Rational PoissonStructure::log_canonical_coefficient(std::size_t i, std::size_t j) const {
    if (class_ != StructureClass::log_canonical)
        throw std::logic_error("pgi::PoissonStructure: log_canonical_coefficient on a " + to_string(class_) + " structure");
    return pi_[i][j].is_zero() ? Rational(0) : pi_[i][j].term_coeff(0);
}

Poly PoissonStructure::bracket(const Poly& f, const Poly& g) const {
    Poly r(M_.ring());
    for (std::size_t i = 0; i < dim(); ++i) {
        Poly dfi = derivative(f, M_.x(i));
        if (dfi.is_zero()) continue;
        for (const auto& e : rows_[i]) r += pi_[i][e.j] * dfi * derivative(g, M_.x(e.j));
    }
    return r;
}

std::vector<Poly> PoissonStructure::hamiltonian_vector_field(const Poly& H) const {
    std::vector<Poly> grad;  // d H / d x_j once each, not once per row
    for (std::size_t j = 0; j < dim(); ++j) grad.push_back(derivative(H, M_.x(j)));
    std::vector<Poly> v;
    for (std::size_t i = 0; i < dim(); ++i) {
        Poly vi(M_.ring());
        for (const auto& e : rows_[i])
            if (!grad[e.j].is_zero()) vi += pi_[i][e.j] * grad[e.j];
        v.push_back(std::move(vi));
    }
    return v;
}

Poly PoissonStructure::jacobiator(std::size_t i, std::size_t j, std::size_t k) const {
    Poly r(M_.ring());
    // pi_al d_l pi_bc over the variables x_l of pi_bc
    auto add = [&](std::size_t a, std::size_t b, std::size_t c) {
        for (std::size_t l : entry_vars(b, c))
            if (!pi_[a][l].is_zero()) r += pi_[a][l] * derivative(pi_[b][c], M_.x(l));
    };
    add(i, j, k);
    add(j, k, i);
    add(k, i, j);
    return r;
}

std::vector<std::array<std::size_t, 3>> PoissonStructure::jacobi_support() const {
    std::set<std::array<std::size_t, 3>> triples;
    for (std::size_t b = 0; b < dim(); ++b)
        for (const auto& [c, vars] : rows_[b])
            for (std::size_t l : vars)
                for (const auto& la : rows_[l]) {  // pi_al = -pi_la != 0
                    const std::size_t a = la.j;
                    std::array<std::size_t, 3> t{a, b, c};
                    if (a == b || b == c || a == c) continue;
                    std::sort(t.begin(), t.end());
                    triples.insert(t);
                }
    return {triples.begin(), triples.end()};
}

std::optional<JacobiFailure> PoissonStructure::jacobi_failure() const {
    for (const auto& [i, j, k] : jacobi_support())
        if (Poly J = jacobiator(i, j, k); !J.is_zero()) return JacobiFailure{i, j, k, std::move(J)};
    return std::nullopt;
}

std::optional<CasimirFailure> PoissonStructure::casimir_failure(const Poly& C) const {
    auto v = hamiltonian_vector_field(C);
    for (std::size_t i = 0; i < v.size(); ++i)
        if (!v[i].is_zero()) return CasimirFailure{i, std::move(v[i])};
    return std::nullopt;
}

}  // namespace pgi
