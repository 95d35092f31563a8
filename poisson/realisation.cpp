#include "poisson/realisation.hpp"

#include "series/composition.hpp"

#include <set>
#include <stdexcept>

namespace pgi {

RealisationChoice parse_realisation_choice(std::string_view text) {
    if (text == "auto") return RealisationChoice::automatic;
    if (text == "closed-form") return RealisationChoice::closed_form;
    if (text == "radial") return RealisationChoice::radial;
    throw std::invalid_argument("realisation must be \"auto\", \"closed-form\" or \"radial\", not \"" +
                                std::string(text) + "\"");
}

std::string to_string(RealisationChoice c) {
    switch (c) {
        case RealisationChoice::automatic:
            return "auto";
        case RealisationChoice::closed_form:
            return "closed-form";
        case RealisationChoice::radial:
            return "radial";
    }
    return "?";
}

bool has_closed_form(StructureClass c) {
    return c != StructureClass::general;
}

std::string to_string(RealisationForm f) {
    switch (f) {
        case RealisationForm::constant:
            return "constant";
        case RealisationForm::lie_poisson:
            return "lie-poisson";
        case RealisationForm::log_canonical:
            return "log-canonical";
        case RealisationForm::radial:
            return "radial";
    }
    return "?";
}

RealisationForm realisation_form(StructureClass c, RealisationChoice choice) {
    if (choice == RealisationChoice::radial || (choice == RealisationChoice::automatic && !has_closed_form(c)))
        return RealisationForm::radial;
    switch (c) {
        case StructureClass::constant:
            return RealisationForm::constant;
        case StructureClass::linear:
            return RealisationForm::lie_poisson;
        case StructureClass::log_canonical:
            return RealisationForm::log_canonical;
        case StructureClass::general:
            break;
    }
    throw std::invalid_argument("\"closed-form\" is not available for a general structure; use \"radial\" or \"auto\"");
}

namespace {

// beta(x, p) = alpha(x, -p): the part of degree m changes sign with m odd.
std::vector<Series> reflect(const std::vector<Series>& alpha) {
    std::vector<Series> beta = alpha;
    for (auto& s : beta)
        for (std::size_t m = 1; m < s.order(); m += 2) s[m] = -s[m];
    return beta;
}

Realisation symmetric(std::string method, std::size_t D, std::vector<Series> alpha) {
    std::vector<Series> beta = reflect(alpha);
    return Realisation{std::move(method), D, std::move(alpha), std::move(beta)};
}

// alpha_i = x_i + O(p^{D+1}), to be completed by each construction.
std::vector<Series> identity_map(const PhaseSpace& M, std::size_t D) {
    std::vector<Series> a;
    for (std::size_t i = 0; i < M.dim(); ++i) a.push_back(Series::constant(M.x_gen(i), D + 1));
    return a;
}

// The linear forms l_ik(p) = sum_j c_ij^k p_j of a linear pi (pi_ij = sum_k c_ij^k x_k): L(p) y = (sum_k l_ik(p)
// y_k)_i.
std::vector<std::vector<Poly>> structure_forms(const PoissonStructure& pi) {
    const PhaseSpace& M = pi.phase_space();
    std::vector<std::vector<Poly>> l(M.dim(), std::vector<Poly>(M.dim(), Poly(M.ring())));
    for (std::size_t i = 0; i < M.dim(); ++i)
        for (std::size_t j = 0; j < M.dim(); ++j)
            if (!pi(i, j).is_zero())
                for (std::size_t k = 0; k < M.dim(); ++k)
                    l[i][k] += derivative(pi(i, j), M.x(k)) * M.p_gen(j);  // c_ij^k p_j
    return l;
}

// (L(p) y)_i = sum_k l_ik(p) y_k.
std::vector<Poly> apply_L(const std::vector<std::vector<Poly>>& l, const std::vector<Poly>& y) {
    std::vector<Poly> out;
    for (const auto& row : l) {
        Poly r(y.front().ring());
        for (std::size_t k = 0; k < y.size(); ++k)
            if (!row[k].is_zero() && !y[k].is_zero()) r += row[k] * y[k];
        out.push_back(std::move(r));
    }
    return out;
}

void require_class(const PoissonStructure& pi, StructureClass c, const char* what) {
    if (pi.structure_class() != c)
        throw std::invalid_argument(std::string(what) + " needs a " + to_string(c) + " structure, not a " +
                                    to_string(pi.structure_class()) + " one");
}

}  // namespace

Realisation constant_realisation(const PoissonStructure& pi, std::size_t D) {
    require_class(pi, StructureClass::constant, "the constant realisation");
    const PhaseSpace& M = pi.phase_space();
    auto alpha = identity_map(M, D);
    // alpha = x - (1/2) pi p
    if (D >= 1)
        for (std::size_t i = 0; i < M.dim(); ++i)
            for (std::size_t j = 0; j < M.dim(); ++j) alpha[i][1] -= Rational(1, 2) * (pi(i, j) * M.p_gen(j));
    return symmetric(to_string(RealisationForm::constant), D, std::move(alpha));
}

Realisation lie_poisson_realisation(const PoissonStructure& pi, std::size_t D) {
    require_class(pi, StructureClass::linear, "the Lie-Poisson realisation");
    const PhaseSpace& M = pi.phase_space();
    auto alpha = identity_map(M, D);
    // alpha = sum_m B_m/m! L(p)^m x, with v_m = L(p)^m x homogeneous of degree m in p
    const auto l = structure_forms(pi);
    std::vector<Poly> v;
    for (std::size_t i = 0; i < M.dim(); ++i) v.push_back(M.x_gen(i));
    for (std::size_t m = 1; m <= D; ++m) {
        v = apply_L(l, v);
        Rational c = bernoulli(m) * inverse_factorial(m);
        for (std::size_t i = 0; i < M.dim(); ++i) alpha[i][m] = c * v[i];
    }
    return symmetric(to_string(RealisationForm::lie_poisson), D, std::move(alpha));
}

Realisation log_canonical_realisation(const PoissonStructure& pi, std::size_t D) {
    require_class(pi, StructureClass::log_canonical, "the log-canonical realisation");
    const PhaseSpace& M = pi.phase_space();
    auto alpha = identity_map(M, D);
    for (std::size_t j = 0; j < M.dim(); ++j) {
        // u_j = (1/2) sum_i a_ij x_i p_i;  alpha_j = sum_m u_j^m/m! x_j
        Poly u(M.ring());
        for (std::size_t i : pi.row_support(j))  // a_ij != 0 exactly where a_ji != 0
            u += (Rational(1, 2) * pi.log_canonical_coefficient(i, j)) * (M.x_gen(i) * M.p_gen(i));
        Poly um = M.x_gen(j);
        for (std::size_t m = 1; m <= D; ++m) {
            um = um * u;
            alpha[j][m] = inverse_factorial(m) * um;
        }
    }
    return symmetric(to_string(RealisationForm::log_canonical), D, std::move(alpha));
}

namespace {

// The x- and p-gradients of one polynomial, kept so each bracket below costs products only.
struct Gradient {
    std::vector<Poly> dx, dp;
    Gradient(const PhaseSpace& M, const Poly& f) {
        for (std::size_t l = 0; l < M.dim(); ++l) {
            dx.push_back(derivative(f, M.x(l)));
            dp.push_back(derivative(f, M.p(l)));
        }
    }
};

// The products whose sum is sign * {F, G}_can, from the gradients of F and G, appended to terms.
void append_canonical_bracket(const Gradient& F, const Gradient& G, const Rational& sign, std::vector<Poly>& terms) {
    for (std::size_t l = 0; l < F.dx.size(); ++l) {
        if (!F.dx[l].is_zero() && !G.dp[l].is_zero()) (terms.push_back(F.dx[l] * G.dp[l]), terms.back() *= sign);
        if (!F.dp[l].is_zero() && !G.dx[l].is_zero()) (terms.push_back(F.dp[l] * G.dx[l]), terms.back() *= -sign);
    }
}

}  // namespace

Realisation radial_realisation(const PoissonStructure& pi, std::size_t D) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim();
    auto alpha = identity_map(M, D);
    std::vector<std::vector<Gradient>> grad(n);  // grad[i][a]: gradients of A_{a,i}, a >= 1
    // R is skew like pi: R_ji = -R_ij (swap a and b), R_ii = 0 (the terms a and b cancel), so i < j only
    std::vector<Poly> entries;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) entries.push_back(pi(i, j));
    // [pi_ij(A_0 + ... + A_m)]_deg m reads A_0..A_m only: the composition is completed one degree per step
    std::vector<std::optional<Series>> images(M.ring()->size());
    for (std::size_t i = 0; i < n; ++i) images[M.x(i)] = alpha[i];
    ComposeByOrder pi_of_alpha(entries, std::move(images), D + 1);  // all entries share the image products
    for (std::size_t m = 0; m < D; ++m) {
        BudgetStage stage(M.ring()->budget(), "radial realisation, terms of degree " + std::to_string(m + 1) + " in p",
                          m + 1, D);
        std::vector<std::vector<Poly>> next(n);  // the terms of (m+2) A_{m+1,j}, summed once (poly.hpp's sum)
        for (std::size_t i = 0, entry = 0; i < n; ++i) {
            for (std::size_t j = i + 1; j < n; ++j, ++entry) {
                // R_ij = [pi_ij(A_0 + ... + A_m)]_deg m - sum_{a+b=m+1, 1<=a,b<=m} {A_a,i, A_b,j}_can
                std::vector<Poly> terms{pi_of_alpha.coefficient(entry, m)};
                for (std::size_t a = 1; a <= m; ++a)
                    append_canonical_bracket(grad[i][a - 1], grad[j][m - a], Rational(-1), terms);
                const Poly R = sum(std::move(terms), M.ring());
                if (R.is_zero()) continue;
                next[j].push_back(M.p_gen(i) * R);
                next[i].push_back(M.p_gen(j) * R);
                next[i].back() *= Rational(-1);
            }
        }
        for (std::size_t j = 0; j < n; ++j) {
            // A_{m+1,j} = 1/(m+2) sum_i p_i R_ij
            alpha[j][m + 1] = Rational(1, static_cast<unsigned long>(m + 2)) * sum(std::move(next[j]), M.ring());
            grad[j].emplace_back(M, alpha[j][m + 1]);
            pi_of_alpha.set_image(M.x(j), m + 1, alpha[j][m + 1]);
        }
    }
    return symmetric(to_string(RealisationForm::radial), D, std::move(alpha));
}

Realisation build_realisation(const PoissonStructure& pi, RealisationChoice choice, std::size_t D) {
    BudgetStage stage(pi.phase_space().ring()->budget(), "realisation through p-degree " + std::to_string(D), 0, 0);
    switch (realisation_form(pi.structure_class(), choice)) {
        case RealisationForm::constant:
            return constant_realisation(pi, D);
        case RealisationForm::lie_poisson:
            return lie_poisson_realisation(pi, D);
        case RealisationForm::log_canonical:
            return log_canonical_realisation(pi, D);
        case RealisationForm::radial:
            break;
    }
    return radial_realisation(pi, D);
}

Realisation truncated(const Realisation& r, std::size_t D) {
    if (D > r.degree)
        throw std::invalid_argument("truncated: degree " + std::to_string(D) + " above the realisation's " +
                                    std::to_string(r.degree));
    Realisation t{r.method, D, {}, {}};
    for (const auto& a : r.alpha) t.alpha.push_back(a.truncated(D + 1));
    for (const auto& b : r.beta) t.beta.push_back(b.truncated(D + 1));
    return t;
}

RealisationPtr DeepestRealisation::through(const PoissonStructure& pi, std::size_t D, std::size_t build_at_least) {
    if (!deepest_ || deepest_->degree < D) {
        deepest_ = std::make_shared<const Realisation>(build_realisation(pi, choice_, std::max(D, build_at_least)));
        ++builds_;
    }
    return deepest_->degree == D ? deepest_ : std::make_shared<const Realisation>(truncated(*deepest_, D));
}

bool is_symmetric(const Realisation& r) {
    if (r.alpha.size() != r.beta.size()) return false;
    for (std::size_t i = 0; i < r.alpha.size(); ++i) {
        const Series &a = r.alpha[i], &b = r.beta[i];
        if (a.order() != b.order()) return false;
        for (std::size_t m = 0; m < a.order(); ++m)
            if (!(m % 2 == 0 ? b[m] == a[m] : b[m] == -a[m])) return false;
    }
    return true;
}

Series canonical_bracket(const PhaseSpace& M, const Series& F, const Series& G) {
    const std::size_t N = F.order();
    if (G.order() != N || N == 0)
        throw std::invalid_argument("pgi::canonical_bracket: series orders differ or are zero");
    Series r(M.ring(), N - 1);
    // d_x keeps the p-degree, d_p lowers it by one: [F,G]_m = sum_{a+b=m+1} {F_a, G_b}_can
    for (std::size_t m = 0; m + 1 < N; ++m)
        for (std::size_t a = 0; a <= m + 1; ++a) r[m] += canonical_bracket(M, F[a], G[m + 1 - a]);
    return r;
}

namespace {

std::optional<RealisationDefect> first_defect(std::string identity, std::size_t i, std::size_t j, const Series& lhs,
                                              const Series& rhs) {
    for (std::size_t m = 0; m < lhs.order(); ++m)
        if (!(lhs[m] == rhs[m])) return RealisationDefect{std::move(identity), i, j, m, lhs[m] - rhs[m]};
    return std::nullopt;
}

// pi_ij(y) for p-graded y, truncated at order N.
Series pi_at(const PoissonStructure& pi, std::size_t i, std::size_t j, const std::vector<Series>& y, std::size_t N) {
    const PhaseSpace& M = pi.phase_space();
    std::vector<std::optional<Series>> images(M.ring()->size());
    std::vector<bool> used(M.ring()->size());  // only the variables pi_ij holds: O(1) images per pair, not n
    for (std::size_t v : used_variables(pi(i, j))) used[v] = true;
    for (std::size_t l = 0; l < M.dim(); ++l)
        if (used[M.x(l)]) images[M.x(l)] = y[l].truncated(N);
    return compose(pi(i, j), images, N);
}

}  // namespace

namespace {

// The coordinates l whose x_l (resp. p_l) a series holds, over all its degrees.
void used_coordinates(const PhaseSpace& M, const Series& s, std::size_t i,
                      std::vector<std::vector<std::size_t>>& x_holders,
                      std::vector<std::vector<std::size_t>>& p_holders) {
    std::vector<bool> any(M.ring()->size(), false);
    for (std::size_t m = 0; m < s.order(); ++m)
        for (std::size_t v : used_variables(s[m])) any[v] = true;
    for (std::size_t l = 0; l < M.dim(); ++l) {
        if (any[M.x(l)]) x_holders[l].push_back(i);
        if (any[M.p(l)]) p_holders[l].push_back(i);
    }
}

// The pairs (i, j) where {F_i, G_j}_can can be non-zero: F_i holds x_l and G_j p_l, or the reverse.
void bracket_pairs(const std::vector<std::vector<std::size_t>>& xF, const std::vector<std::vector<std::size_t>>& pF,
                   const std::vector<std::vector<std::size_t>>& xG, const std::vector<std::vector<std::size_t>>& pG,
                   std::set<std::pair<std::size_t, std::size_t>>& pairs) {
    for (std::size_t l = 0; l < xF.size(); ++l) {
        for (std::size_t i : xF[l])
            for (std::size_t j : pG[l]) pairs.insert({i, j});
        for (std::size_t i : pF[l])
            for (std::size_t j : xG[l]) pairs.insert({i, j});
    }
}

}  // namespace

std::optional<RealisationDefect> realisation_defect(const PoissonStructure& pi, const Realisation& r) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim(), N = r.degree;  // the identities hold in degrees < D
    if (N == 0) return std::nullopt;
    // A pair whose canonical brackets are 0 term by term and whose pi_ij is 0 holds without computing:
    // only the pairs that interact are checked (none in a bracket-free scene), in the order (i, j).
    std::vector<std::vector<std::size_t>> xA(n), pA(n), xB(n), pB(n);
    for (std::size_t i = 0; i < n; ++i) {
        used_coordinates(M, r.alpha[i], i, xA, pA);
        used_coordinates(M, r.beta[i], i, xB, pB);
    }
    std::set<std::pair<std::size_t, std::size_t>> pairs;
    bracket_pairs(xA, pA, xA, pA, pairs);
    bracket_pairs(xB, pB, xB, pB, pairs);
    bracket_pairs(xA, pA, xB, pB, pairs);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            if (!pi(i, j).is_zero()) pairs.insert({i, j});
    for (const auto& [i, j] : pairs) {
        BudgetStage stage(M.ring()->budget(), "realisation identities, row " + M.coordinates()[i], i + 1, n);
        if (i < j) {
            if (auto d = first_defect("{alpha_i, alpha_j} = pi_ij(alpha)", i, j,
                                      canonical_bracket(M, r.alpha[i], r.alpha[j]), pi_at(pi, i, j, r.alpha, N)))
                return d;
            if (auto d =
                    first_defect("{beta_i, beta_j} = -pi_ij(beta)", i, j, canonical_bracket(M, r.beta[i], r.beta[j]),
                                 Rational(-1) * pi_at(pi, i, j, r.beta, N)))
                return d;
        }
        if (auto d = first_defect("{alpha_i, beta_j} = 0", i, j, canonical_bracket(M, r.alpha[i], r.beta[j]),
                                  M.zero_series(N)))
            return d;
    }
    return std::nullopt;
}

}  // namespace pgi
