#include "poisson/structure.hpp"

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
            if (!(pi_[i][j] == -pi_[j][i]))
                throw std::invalid_argument("pi is not skew-symmetric at (" + M_.coordinates()[i] + ", " +
                                            M_.coordinates()[j] + "): {" + M_.coordinates()[i] + "," +
                                            M_.coordinates()[j] + "} = " + pi_[i][j].to_string() + " but {" +
                                            M_.coordinates()[j] + "," + M_.coordinates()[i] + "} = " +
                                            pi_[j][i].to_string());
    class_ = classify(M_, pi_);
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
        for (std::size_t j = 0; j < dim(); ++j)
            if (!pi_[i][j].is_zero()) r += pi_[i][j] * dfi * derivative(g, M_.x(j));
    }
    return r;
}

std::vector<Poly> PoissonStructure::hamiltonian_vector_field(const Poly& H) const {
    std::vector<Poly> v;
    for (std::size_t i = 0; i < dim(); ++i) {
        Poly vi(M_.ring());
        for (std::size_t j = 0; j < dim(); ++j) vi += pi_[i][j] * derivative(H, M_.x(j));
        v.push_back(std::move(vi));
    }
    return v;
}

Poly PoissonStructure::jacobiator(std::size_t i, std::size_t j, std::size_t k) const {
    Poly r(M_.ring());
    for (std::size_t l = 0; l < dim(); ++l) {
        r += pi_[i][l] * derivative(pi_[j][k], M_.x(l));
        r += pi_[j][l] * derivative(pi_[k][i], M_.x(l));
        r += pi_[k][l] * derivative(pi_[i][j], M_.x(l));
    }
    return r;
}

std::optional<JacobiFailure> PoissonStructure::jacobi_failure() const {
    for (std::size_t i = 0; i < dim(); ++i)
        for (std::size_t j = i + 1; j < dim(); ++j)
            for (std::size_t k = j + 1; k < dim(); ++k)
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
