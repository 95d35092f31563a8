#include "poisson/structure.hpp"

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

namespace pgi {

std::string to_string(StructureClass c) {
    switch (c) {
        case StructureClass::constant:
            return "constant";
        case StructureClass::linear:
            return "linear";
        case StructureClass::log_canonical:
            return "log-canonical";
        case StructureClass::general:
            return "general";
    }
    return "?";
}

namespace {

using Entries = std::map<std::pair<std::size_t, std::size_t>, Poly>;

bool all_entries(const Entries& pi, auto pred) {
    for (const auto& [ij, f] : pi)
        if (!f.is_zero() && !pred(ij.first, ij.second, f)) return false;
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

StructureClass classify(const PhaseSpace& M, const Entries& pi) {
    const VarMask all(M.ring()->size(), true);
    if (all_entries(pi, [](auto, auto, const Poly& f) { return f.total_degree() == 0; }))
        return StructureClass::constant;
    if (all_entries(pi, [&](auto, auto, const Poly& f) { return homogeneous_part(f, all, 1) == f; }))
        return StructureClass::linear;
    if (all_entries(pi, is_log_canonical_entry)) return StructureClass::log_canonical;
    return StructureClass::general;
}

}  // namespace

namespace {

// The non-zero entries of an n x n matrix (which must be n x n).
Entries nonzero_entries(const PhaseSpace& M, std::vector<std::vector<Poly>> matrix) {
    const std::size_t n = M.dim();
    if (matrix.size() != n)
        throw std::invalid_argument("pi must be a " + std::to_string(n) + " x " + std::to_string(n) + " matrix");
    for (const auto& row : matrix)
        if (row.size() != n)
            throw std::invalid_argument("pi must be a " + std::to_string(n) + " x " + std::to_string(n) + " matrix");
    Entries entries;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            if (!matrix[i][j].is_zero()) entries.emplace(std::pair{i, j}, std::move(matrix[i][j]));
    return entries;
}

}  // namespace

PoissonStructure::PoissonStructure(PhaseSpace M, std::vector<std::vector<Poly>> matrix)
    : PoissonStructure(M, nonzero_entries(M, std::move(matrix))) {}

PoissonStructure::PoissonStructure(PhaseSpace M, std::map<std::pair<std::size_t, std::size_t>, Poly> entries)
    : M_(std::move(M)), zero_(M_.ring()), class_(StructureClass::general) {
    const std::size_t n = M_.dim();
    for (auto it = entries.begin(); it != entries.end();) it = it->second.is_zero() ? entries.erase(it) : std::next(it);
    const auto at = [&](std::size_t i, std::size_t j) -> const Poly& {
        auto it = entries.find({i, j});
        return it == entries.end() ? zero_ : it->second;
    };
    // the first pair i <= j (in that order) where pi_ij + pi_ji != 0
    std::optional<std::pair<std::size_t, std::size_t>> bad;
    for (const auto& [ij, f] : entries) {
        if (ij.first >= n || ij.second >= n)
            throw std::invalid_argument("pi: an entry outside the " + std::to_string(n) + " coordinates");
        const std::pair<std::size_t, std::size_t> pair{std::min(ij.first, ij.second), std::max(ij.first, ij.second)};
        if (!(f + at(ij.second, ij.first)).is_zero() && (!bad || pair < *bad)) bad = pair;
    }
    if (bad) {
        const auto [i, j] = *bad;
        throw std::invalid_argument("pi is not skew-symmetric at (" + M_.coordinates()[i] + ", " + M_.coordinates()[j] +
                                    "): {" + M_.coordinates()[i] + "," + M_.coordinates()[j] +
                                    "} = " + at(i, j).to_string() + " but {" + M_.coordinates()[j] + "," +
                                    M_.coordinates()[i] + "} = " + at(j, i).to_string());
    }
    class_ = classify(M_, entries);
    rows_.resize(n);
    std::vector<bool> used(M_.ring()->size());
    for (auto& [ij, f] : entries) {  // by (i, j): each row's j increasing
        std::fill(used.begin(), used.end(), false);
        for (std::size_t v : used_variables(f)) used[v] = true;
        Entry e{ij.second, {}, std::move(f)};
        for (std::size_t l = 0; l < n; ++l)
            if (used[M_.x(l)]) e.vars.push_back(l);
        rows_[ij.first].push_back(std::move(e));
    }
}

const Poly& PoissonStructure::operator()(std::size_t i, std::size_t j) const {
    auto it =
        std::lower_bound(rows_[i].begin(), rows_[i].end(), j, [](const Entry& e, std::size_t v) { return e.j < v; });
    return it != rows_[i].end() && it->j == j ? it->value : zero_;
}

const std::vector<std::size_t>& PoissonStructure::entry_vars(std::size_t i, std::size_t j) const {
    static const std::vector<std::size_t> none;
    auto it =
        std::lower_bound(rows_[i].begin(), rows_[i].end(), j, [](const Entry& e, std::size_t v) { return e.j < v; });
    return it != rows_[i].end() && it->j == j ? it->vars : none;
}

std::size_t PoissonStructure::moving_dimension() const {
    std::vector<bool> read(dim(), false);
    for (const auto& row : rows_)
        for (const Entry& e : row)
            for (std::size_t v : e.vars) read[v] = true;
    std::size_t n = dim();
    while (n > 0 && rows_[n - 1].empty() && !read[n - 1]) --n;
    return n > 0 ? n : dim();
}

std::vector<std::size_t> PoissonStructure::row_support(std::size_t i) const {
    std::vector<std::size_t> js;
    for (const auto& e : rows_[i]) js.push_back(e.j);
    return js;
}

Rational PoissonStructure::log_canonical_coefficient(std::size_t i, std::size_t j) const {
    if (class_ != StructureClass::log_canonical)
        throw std::logic_error("pgi::PoissonStructure: log_canonical_coefficient on a " + to_string(class_) +
                               " structure");
    const Poly& a = (*this)(i, j);
    return a.is_zero() ? Rational(0) : a.term_coeff(0);
}

Poly PoissonStructure::bracket(const Poly& f, const Poly& g) const {
    Poly r(M_.ring());
    for (std::size_t i = 0; i < dim(); ++i) {
        Poly dfi = derivative(f, M_.x(i));
        if (dfi.is_zero()) continue;
        for (const auto& e : rows_[i]) r += e.value * dfi * derivative(g, M_.x(e.j));
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
            if (!grad[e.j].is_zero()) vi += e.value * grad[e.j];
        v.push_back(std::move(vi));
    }
    return v;
}

Poly PoissonStructure::jacobiator(std::size_t i, std::size_t j, std::size_t k) const {
    Poly r(M_.ring());
    // pi_al d_l pi_bc over the variables x_l of pi_bc
    auto add = [&](std::size_t a, std::size_t b, std::size_t c) {
        for (std::size_t l : entry_vars(b, c))
            if (const Poly& p = (*this)(a, l); !p.is_zero()) r += p * derivative((*this)(b, c), M_.x(l));
    };
    add(i, j, k);
    add(j, k, i);
    add(k, i, j);
    return r;
}

std::vector<std::array<std::size_t, 3>> PoissonStructure::jacobi_support() const {
    std::set<std::array<std::size_t, 3>> triples;
    for (std::size_t b = 0; b < dim(); ++b)
        for (const auto& [c, vars, value] : rows_[b])
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
