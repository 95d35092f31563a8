#include "poisson/realisation_eval.hpp"

#include "poisson/log_canonical.ipp"
#include "poisson/detail/newton_rules.hpp"

#include <flint/fmpq.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

namespace pgi {

RealisationValues::RealisationValues(std::size_t n)
    : alpha(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n))),
      delta(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n))),
      alpha_x(Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n))), alpha_p(alpha_x),
      delta_x(alpha_x), delta_p(alpha_x) {}

RealisationCheck::RealisationCheck(std::size_t n)
    : alpha(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n))), delta(alpha), size(alpha), shift(alpha) {}

Poly absolute_coefficients(const Poly& f) {
    Poly a = f;
    fmpq_abs(a.get_mut()->content, a.get_mut()->content);
    for (std::size_t i = 0; i < a.length(); ++i)
        fmpz_abs(a.get_mut()->zpoly->coeffs + i, a.get_mut()->zpoly->coeffs + i);
    return a;
}

namespace {

// The pattern of d f_i / d v_l over the variables v_l = vars[l]: the variables each f_i holds.
SparsePattern derivative_pattern(const std::vector<std::vector<std::size_t>>& used,
                                 const std::vector<std::size_t>& vars) {
    std::vector<int> column_of(vars.empty() ? 0 : *std::max_element(vars.begin(), vars.end()) + 1, -1);
    for (std::size_t l = 0; l < vars.size(); ++l) column_of[vars[l]] = static_cast<int>(l);
    std::vector<std::vector<int>> columns(vars.size());
    for (std::size_t i = 0; i < used.size(); ++i)
        for (std::size_t v : used[i])
            if (v < column_of.size() && column_of[v] >= 0)
                columns[std::size_t(column_of[v])].push_back(static_cast<int>(i));
    return SparsePattern::from_columns(used.size(), std::move(columns));
}

// d f_i / d vars[l] for every entry (i, l) of the pattern, in pattern order.
void push_derivatives(const std::vector<Poly>& f, const SparsePattern& pattern, const std::vector<std::size_t>& vars,
                      std::vector<Poly>& out) {
    for (std::size_t l = 0; l < pattern.cols; ++l)
        for (int k = pattern.outer[l]; k < pattern.outer[l + 1]; ++k)
            out.push_back(derivative(f[std::size_t(pattern.inner[std::size_t(k)])], vars[l]));
}

}  // namespace

namespace {

// The polynomial form's compiled maps on the first `count` coordinates (the components alpha_i, delta_i for i < count,
// read at x_0..x_{count-1}, p_0..p_{count-1}): alpha, delta and their derivatives where a component holds the variable
// (alpha_i and delta_i together); the acceptance test's values alpha - x (check's shift: alpha = x + shift) and the
// neglected parts, the sizes (every coefficient made positive), and delta apart (the Newton step reads it once, at the
// base point it accepts and polishes).
struct PolynomialMaps {
    SparsePattern pattern_x, pattern_p;
    CompiledMap map, values, size, delta;
    std::size_t outputs = 0;
};
PolynomialMaps polynomial_maps(const PhaseSpace& M, const std::vector<Poly>& alpha, const std::vector<Poly>& delta,
                               const std::vector<Poly>& neglected, std::size_t count) {
    std::vector<std::size_t> xs, ps;
    for (std::size_t i = 0; i < count; ++i) xs.push_back(M.x(i)), ps.push_back(M.p(i));
    std::vector<std::size_t> inputs = xs;
    inputs.insert(inputs.end(), ps.begin(), ps.end());
    const std::vector<Poly> a(alpha.begin(), alpha.begin() + std::ptrdiff_t(count)),
        d(delta.begin(), delta.begin() + std::ptrdiff_t(count));
    std::vector<std::vector<std::size_t>> used(count);
    for (std::size_t i = 0; i < count; ++i) {
        used[i] = used_variables(a[i]);
        const auto u = used_variables(d[i]);
        used[i].insert(used[i].end(), u.begin(), u.end());
    }
    PolynomialMaps m;
    m.pattern_x = derivative_pattern(used, xs);
    m.pattern_p = derivative_pattern(used, ps);
    std::vector<Poly> outputs = a;
    outputs.insert(outputs.end(), d.begin(), d.end());
    for (const auto* f : {&a, &d}) push_derivatives(*f, m.pattern_x, xs, outputs);
    for (const auto* f : {&a, &d}) push_derivatives(*f, m.pattern_p, ps, outputs);
    m.map = CompiledMap::build(outputs, inputs);
    std::vector<Poly> values, sizes;
    for (std::size_t i = 0; i < count; ++i) values.push_back(a[i] - M.x_gen(i));
    values.insert(values.end(), neglected.begin(), neglected.end());
    for (const auto& f : a) sizes.push_back(absolute_coefficients(f));
    m.values = CompiledMap::build(values, inputs);
    m.size = CompiledMap::build(sizes, inputs);
    m.delta = CompiledMap::build(d, inputs);
    m.outputs = std::max(outputs.size(), values.size());
    return m;
}

// The leading coordinates that read every other: n less the trailing ones the realisation leaves alone (alpha_w = x_w,
// delta_w = 0) whose x_w and p_w no leading component nor neglected part reads.
std::size_t leading_coordinates(const PhaseSpace& M, const std::vector<Poly>& alpha, const std::vector<Poly>& delta,
                                const std::vector<Poly>& neglected) {
    const std::size_t n = M.dim();
    std::size_t lead = n;
    while (lead > 0 && alpha[lead - 1] == M.x_gen(lead - 1) && delta[lead - 1].is_zero()) --lead;
    const auto reads_trailing = [&](const Poly& f) {
        for (std::size_t v : used_variables(f))
            for (std::size_t w = lead; w < n; ++w)
                if (v == M.x(w) || v == M.p(w)) return true;
        return false;
    };
    for (std::size_t i = 0; i < lead; ++i)
        if (reads_trailing(alpha[i]) || reads_trailing(delta[i])) return n;
    for (const Poly& f : neglected)
        if (reads_trailing(f)) return n;
    return lead;
}

}  // namespace

RealisationEvaluator RealisationEvaluator::polynomial(const PoissonStructure& pi, const Realisation& r,
                                                      const std::vector<Poly>& neglected) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim();
    std::vector<Poly> alpha, delta;
    for (std::size_t i = 0; i < n; ++i) {
        alpha.push_back(r.alpha[i].sum());
        delta.push_back(r.beta[i].sum() - alpha.back());  // the odd part, times -2: its own expression
    }
    RealisationEvaluator e;
    e.n_ = n;
    e.form_ = Form::polynomial;
    PolynomialMaps all = polynomial_maps(M, alpha, delta, neglected, n);
    e.pattern_x_ = std::move(all.pattern_x);
    e.pattern_p_ = std::move(all.pattern_p);
    e.map_ = std::move(all.map);
    e.values_map_ = std::move(all.values);
    e.size_map_ = std::move(all.size);
    e.delta_map_ = std::move(all.delta);
    e.in_.resize(static_cast<Eigen::Index>(2 * n));
    e.out_.resize(static_cast<Eigen::Index>(all.outputs));
    e.lead_ = leading_coordinates(M, alpha, delta, neglected);
    if (e.lead_ < n) {
        PolynomialMaps lead = polynomial_maps(M, alpha, delta, neglected, e.lead_);
        e.leading_ = {std::move(lead.pattern_x), std::move(lead.pattern_p), std::move(lead.map),
                      std::move(lead.values),    std::move(lead.size),      std::move(lead.delta)};
    }
    return e;
}

RealisationEvaluator RealisationEvaluator::log_canonical(const PoissonStructure& pi) {
    RealisationEvaluator e;
    const std::size_t n = pi.dim();
    e.n_ = n;
    // the trailing coordinates with zero rows (a scheme's parameters): alpha_w = x_w, and no u_j reads them
    e.lead_ = n;
    while (e.lead_ > 0 && pi.row_support(e.lead_ - 1).empty()) --e.lead_;
    e.form_ = Form::log_canonical;
    // a_lj != 0 exactly where pi_jl != 0: the structure's pattern, symmetric
    std::vector<std::vector<int>> columns(n), with_diagonal(n);
    for (std::size_t j = 0; j < n; ++j) {
        for (std::size_t l : pi.row_support(j)) columns[j].push_back(static_cast<int>(l));
        with_diagonal[j] = columns[j];
        with_diagonal[j].push_back(static_cast<int>(j));
    }
    e.a_pattern_ = SparsePattern::from_columns(n, columns);
    e.pattern_p_ = e.a_pattern_;  // entry (j, l) of alpha_p: a_lj != 0, the same symmetric pattern
    e.pattern_x_ = SparsePattern::from_columns(n, std::move(with_diagonal));
    for (std::size_t j = 0; j < n; ++j) {
        e.diagonal_x_.push_back(static_cast<int>(e.pattern_x_.find(int(j), int(j))));
        for (int k = e.a_pattern_.outer[j]; k < e.a_pattern_.outer[j + 1]; ++k) {
            const int l = e.a_pattern_.inner[std::size_t(k)];
            e.a_values_.push_back(pi.log_canonical_coefficient(std::size_t(l), j).to_double());
            e.a_to_x_.push_back(static_cast<int>(e.pattern_x_.find(int(j), l)));
            e.a_to_p_.push_back(static_cast<int>(e.pattern_p_.find(int(j), l)));
        }
    }
    e.u_.resize(static_cast<Eigen::Index>(n));
    return e;
}

namespace {

// C_j(i, k) = c_ij^k = d pi_ij / d x_k, so that L(p) = sum_j p_j C_j and L(p) x = pi(x) p.
std::vector<Eigen::MatrixXd> structure_matrices(const PoissonStructure& pi) {
    const PhaseSpace& M = pi.phase_space();
    const auto n = static_cast<Eigen::Index>(pi.dim());
    std::vector<Eigen::MatrixXd> Cs;
    for (Eigen::Index j = 0; j < n; ++j) {
        Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
        for (Eigen::Index i = 0; i < n; ++i)
            for (Eigen::Index k = 0; k < n; ++k) {
                Poly c = derivative(pi(static_cast<std::size_t>(i), static_cast<std::size_t>(j)),
                                    M.x(static_cast<std::size_t>(k)));
                if (!c.is_zero()) C(i, k) = c.term_coeff(0).to_double();
            }
        Cs.push_back(std::move(C));
    }
    return Cs;
}

}  // namespace

namespace {

constexpr double two_pi = 6.283185307179586;

// |L|_inf, the norm that bounds |L^m x|_inf by |L|^m |x|_inf.
double operator_norm(const Eigen::MatrixXd& L) {
    double worst = 0;
    for (Eigen::Index i = 0; i < L.rows(); ++i) {
        double row = 0;
        for (Eigen::Index k = 0; k < L.cols(); ++k) row += std::abs(L(i, k));
        worst = std::max(worst, row);
    }
    return worst;
}

// The |L|_inf below which the Bernoulli series through degree D has a tail under u/8 relative to |x|:
// |B_m / m!| = 2 zeta(m) / (2 pi)^m <= 3.3 / (2 pi)^m for even m >= 2 (the odd ones past B_1 vanish), so
// the tail is at most 3.3 q^m0 / (1 - q^2), q = |L| / 2 pi, m0 the first even degree past D; q <= 1/2.
double series_radius_for(std::size_t D) {
    const std::size_t m0 = D % 2 ? D + 1 : D + 2;
    return two_pi * std::min(0.5, std::pow(unit_roundoff / 8 * 0.75 / 3.3, 1.0 / double(m0)));
}

// Q(z) = (z/2) coth(z/2) = sum_j B_2j z^2j / (2j)!, at |Z|_inf <= 1 through j = 11: the tail is below
// 3.3 (1 / 2 pi)^24 / (1 - (1 / 2 pi)^2) < 2e-19.
constexpr std::size_t coth_terms = 12;

}  // namespace

RealisationEvaluator RealisationEvaluator::lie_poisson(const PoissonStructure& pi, std::size_t D) {
    const auto n = static_cast<Eigen::Index>(pi.dim());
    RealisationEvaluator e;
    e.n_ = e.lead_ = pi.dim();
    e.moving_ = pi.moving_dimension();
    e.form_ = Form::lie_poisson;
    e.C_ = structure_matrices(pi);
    for (std::size_t m = 0; m <= D; ++m) {
        const Rational b = bernoulli(m) * inverse_factorial(m);
        e.b_.push_back(b.to_double());
        e.b_low_.push_back((b - Rational::from_double(e.b_.back())).to_double());
    }
    for (std::size_t j = 0; j < coth_terms; ++j)
        e.q_.push_back((bernoulli(2 * j) * inverse_factorial(2 * j)).to_double());
    e.radius_ = series_radius_for(D);
    e.v_prev_.resize(n);
    e.v_next_.resize(n);
    for (auto* M :
         {&e.L_, &e.W_prev_, &e.W_next_, &e.power_, &e.tmp_, &e.Z_, &e.Y_, &e.Q_, &e.Qn_, &e.A2_, &e.M_, &e.G_})
        M->resize(n, n);
    e.dQ_.assign(static_cast<std::size_t>(2 * n), Eigen::MatrixXd(n, n));  // dQ/dp_j, then d(Z^2)/dp_j
    e.lu_ = Eigen::PartialPivLU<Eigen::MatrixXd>(n);
    e.pattern_x_ = e.pattern_p_ = SparsePattern::dense(e.n_, e.n_);
    e.dense_ = RealisationValues(e.n_);
    return e;
}

double RealisationEvaluator::operator_norm_at(const Eigen::VectorXd& p) const {
    form_L(p);
    return operator_norm(L_);
}

std::size_t RealisationEvaluator::series_degree_for(double norm, std::size_t D_min, std::size_t D_max) {
    std::size_t D = D_min;
    while (D < D_max && series_radius_for(D) < norm) ++D;
    return D;
}

namespace {

// The so(3) form's three coordinates (RealisationEvaluator::has_rotation_form), if pi has them: the coordinates of its
// non-zero rows, each C_j skew on them and zero off them (an entry that holds another coordinate is refused).
std::optional<std::array<int, 3>> rotation_block(const PoissonStructure& pi) {
    if (pi.dim() < 3 || pi.structure_class() != StructureClass::linear) return std::nullopt;
    std::vector<int> rows;
    for (std::size_t i = 0; i < pi.dim(); ++i)
        if (!pi.row_support(i).empty()) rows.push_back(static_cast<int>(i));
    if (rows.size() != 3) return std::nullopt;
    const std::array<int, 3> block{rows[0], rows[1], rows[2]};
    const std::vector<Eigen::MatrixXd> Cs = structure_matrices(pi);
    for (const int j : block) {
        Eigen::MatrixXd C = Cs[std::size_t(j)];
        Eigen::Matrix3d on;
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) on(i, k) = C(block[i], block[k]), C(block[i], block[k]) = 0;
        if (on != -on.transpose() || !C.isZero(0)) return std::nullopt;
    }
    return block;
}

}  // namespace

bool RealisationEvaluator::has_rotation_form(const PoissonStructure& pi) {
    return rotation_block(pi).has_value();
}

RealisationEvaluator RealisationEvaluator::rotation(const PoissonStructure& pi) {
    const auto block = rotation_block(pi);
    if (!block) throw std::invalid_argument("RealisationEvaluator::rotation: pi is not of so(3) type");
    RealisationEvaluator e;
    e.n_ = e.lead_ = pi.dim();
    e.form_ = Form::rotation;
    e.C_ = structure_matrices(pi);
    // the even Bernoulli coefficients b_2j = B_2j/(2j)!, j = 1..20, for h(s) near s = 0
    for (std::size_t j = 1; j <= 20; ++j) e.b_.push_back((bernoulli(2 * j) * inverse_factorial(2 * j)).to_double());
    for (std::size_t j = 1; j < 20; ++j) e.b_.push_back(-double(j) * e.b_[j]);  // h's derivative (rotation_coefficient)
    const int a = (*block)[0], b = (*block)[1], c = (*block)[2];
    for (std::size_t j = 0; j < 3; ++j) {  // once here, not at every evaluation
        const Eigen::MatrixXd& C = e.C_[std::size_t((*block)[j])];
        e.block_[j] = (*block)[j];
        e.axial_[j][0] = C(c, b);
        e.axial_[j][1] = C(a, c);
        e.axial_[j][2] = C(b, a);
    }
    const double s = e.axial_[0][0];
    bool axes = s == 1 || s == -1;
    for (std::size_t j = 0; j < 3; ++j)
        for (std::size_t i = 0; i < 3; ++i) axes = axes && e.axial_[j][i] == (i == j ? s : 0.0);
    e.axial_sign_ = axes ? s : 0;
    e.pattern_x_ = e.pattern_p_ = SparsePattern::dense(e.n_, e.n_);
    e.dense_ = RealisationValues(e.n_);
    return e;
}

std::size_t RealisationEvaluator::cost(bool sparse) const {
    const std::size_t n = n_;
    switch (form_) {
        case Form::log_canonical:
            return sparse ? 12 * a_pattern_.nonzeros() + 20 * n : 6 * n * n + 20 * n;
        case Form::lie_poisson:
            return b_.size() * (2 * n * n * n + 3 * n * n);
        case Form::rotation:
            return 150;
        case Form::polynomial:
            break;
    }
    return map_.num_terms() + map_.num_monomials();
}

std::vector<CompiledMap*> RealisationEvaluator::compiled_maps() {
    if (form_ != Form::polynomial) return {};
    return {&map_, &values_map_, &size_map_, &delta_map_};
}

const double* RealisationEvaluator::eval_polynomial(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                                                    Eigen::VectorXd& alpha, Eigen::VectorXd& delta) const {
    const auto n = static_cast<Eigen::Index>(n_);
    in_.head(n) = x;
    in_.tail(n) = p;
    map_.eval(in_.data(), out_.data());
    alpha = out_.segment(0, n);
    delta = out_.segment(n, n);
    return out_.data() + 2 * n;
}

// Sized for both maps of the polynomial form (and for CompiledMap::eval_batch's blocks of a Pack). Here, not with
// the lane kernels: lane_step_avx2.cpp must not compile std::vector<double>'s members (poisson/lane_step_avx2.cpp).
template <class T>
LaneMapScratch<T> RealisationEvaluator::lane_scratch() const {
    LaneMapScratch<T> s;
    s.in.resize(2 * n_);
    s.out.resize(std::max({map_.num_outputs(), values_map_.num_outputs(), n_}));
    if constexpr (!std::is_same_v<T, double>) {
        std::size_t block = 0;
        for (const CompiledMap* m : {&map_, &values_map_, &size_map_, &delta_map_, &leading_.map, &leading_.values,
                                     &leading_.size, &leading_.delta})
            block = std::max(block, m->num_monomials() + m->num_inputs() + m->num_outputs());
        s.map.resize(block * CompiledMap::batch_lanes);
    }
    return s;
}

template LaneMapScratch<double> RealisationEvaluator::lane_scratch<double>() const;
template LaneMapScratch<lanes::Pack> RealisationEvaluator::lane_scratch<lanes::Pack>() const;
template LaneMapScratch<lanes::Pack4> RealisationEvaluator::lane_scratch<lanes::Pack4>() const;

void RealisationEvaluator::eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const {
    switch (form_) {
        case Form::log_canonical:
            eval_log_canonical(x, p, v);
            return;
        case Form::lie_poisson:
            eval_lie_poisson(x, p, v);
            return;
        case Form::rotation:
            eval_rotation(x, p, v);
            return;
        case Form::polynomial:
            break;
    }
    const double* d = eval_polynomial(x, p, v.alpha, v.delta);
    const std::size_t nx = pattern_x_.nonzeros(), np = pattern_p_.nonzeros();
    pattern_x_.scatter(d, v.alpha_x);
    pattern_x_.scatter(d + nx, v.delta_x);
    pattern_p_.scatter(d + 2 * nx, v.alpha_p);
    pattern_p_.scatter(d + 2 * nx + np, v.delta_p);
}

namespace {

// y = A x for small column-major A (n x n): plain loops, as Eigen's dynamic kernels cost more than
// the arithmetic at n = 3..10. N > 0 fixes n at compile time (the loops unroll), N = 0 reads it.
template <int N>
inline void matvec(const double* A, const double* x, double* y, Eigen::Index n_runtime) {
    const Eigen::Index n = N > 0 ? N : n_runtime;
    for (Eigen::Index i = 0; i < n; ++i) y[i] = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) {
        const double xk = x[k];
        const double* col = A + k * n;
        for (Eigen::Index i = 0; i < n; ++i) y[i] += col[i] * xk;
    }
}

// Scratch of the Lie-Poisson series, owned by the evaluator: v_{m-1}, v_m, W_{m-1}, W_m, L^m, L^{m+1}.
struct LieScratch {
    double *vp, *vn, *Wp, *Wn, *P, *T;
};

// alpha = sum_m b_m L^m x with alpha_x = sum_m b_m L^m and alpha_p (column j) = sum_m b_m d(L^m x)/dp_j.
// v_m = L^m x; W_m = d v_m / dp, column j = C_j v_{m-1} + L (column j of W_{m-1}).
template <int N>
void lie_poisson_series(const std::vector<double>& b, const std::vector<Eigen::MatrixXd>& C, const double* L,
                        const double* x, Eigen::Index n_runtime, LieScratch s, double* alpha, double* ax, double* ap) {
    const Eigen::Index n = N > 0 ? N : n_runtime;
    for (Eigen::Index i = 0; i < n; ++i) {
        s.vp[i] = x[i];
        alpha[i] = b[0] * x[i];
    }
    for (Eigen::Index e = 0; e < n * n; ++e) s.Wp[e] = 0.0, s.P[e] = 0.0, ax[e] = 0.0, ap[e] = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) s.P[i * n + i] = 1.0, ax[i * n + i] = b[0];
    for (std::size_t m = 1; m < b.size(); ++m) {
        matvec<N>(L, s.vp, s.vn, n);
        for (Eigen::Index j = 0; j < n; ++j) {
            matvec<N>(L, s.Wp + j * n, s.Wn + j * n, n);
            const double* Cj = C[static_cast<std::size_t>(j)].data();
            for (Eigen::Index k = 0; k < n; ++k) {
                const double vk = s.vp[k];
                for (Eigen::Index i = 0; i < n; ++i) s.Wn[j * n + i] += Cj[k * n + i] * vk;
            }
            matvec<N>(L, s.P + j * n, s.T + j * n, n);
        }
        std::swap(s.P, s.T);
        const double bm = b[m];
        if (bm != 0) {
            for (Eigen::Index i = 0; i < n; ++i) alpha[i] += bm * s.vn[i];
            for (Eigen::Index e = 0; e < n * n; ++e) ax[e] += bm * s.P[e], ap[e] += bm * s.Wn[e];
        }
        std::swap(s.vp, s.vn);
        std::swap(s.Wp, s.Wn);
    }
}

}  // namespace

void RealisationEvaluator::form_L(const Eigen::VectorXd& p) const {
    // L(p) = sum_j p_j C_j, so L(p) x = pi(x) p
    L_.setZero();
    for (Eigen::Index j = 0; j < L_.rows(); ++j) L_ += p[j] * C_[static_cast<std::size_t>(j)];
}

// Q_ = Q(L) with Q(z) = (z/2) coth(z/2), and with derivatives dQ_[j] = dQ(L)[C_j] = d Q(L(p)) / d p_j:
// Q's series at Z = L / 2^s, |Z|_inf <= 1 (Horner in Y = Z^2), then s doublings
// Q(2Z) = Q(Z)^{-1} (A^2 + Q(Z)^2), A = Z/2 (coth 2a = (1 + coth^2 a) / (2 coth a)), differentiated:
// dQ(2Z) = Q^{-1} (dA A + A dA + dQ Q + Q dQ - dQ Q(2Z)) (from Q Q(2Z) = A^2 + Q^2; dA and dQ do not commute).
void RealisationEvaluator::coth_form(bool derivatives) const {
    const auto n = L_.rows();
    const std::size_t dirs = derivatives ? static_cast<std::size_t>(n) : 0;
    int s = 0;
    const double norm = operator_norm(L_);
    if (norm > 1) std::frexp(norm, &s);  // norm < 2^s
    double c = std::ldexp(1.0, -s);      // Z = c L, dZ/dp_j = c C_j
    Z_ = c * L_;
    Y_.noalias() = Z_ * Z_;
    for (std::size_t j = 0; j < dirs; ++j) {  // dY_j = E Z + Z E, E = c C_j, kept in dQ_[n + j]
        auto& dY = dQ_[dirs + j];
        dY.noalias() = c * (C_[j] * Z_);
        dY.noalias() += c * (Z_ * C_[j]);
        dQ_[j].setZero();
    }
    Q_ = q_.back() * Eigen::MatrixXd::Identity(n, n);
    for (std::size_t i = q_.size() - 1; i-- > 0;) {
        for (std::size_t j = 0; j < dirs; ++j) {  // d(Q Y + q I) = dQ Y + Q dY, with Q before its update
            M_.noalias() = dQ_[j] * Y_;
            M_.noalias() += Q_ * dQ_[dirs + j];
            dQ_[j] = M_;
        }
        Qn_.noalias() = Q_ * Y_;
        Q_ = Qn_;
        Q_.diagonal().array() += q_[i];
    }
    for (int k = 0; k < s; ++k, c *= 2) {
        A2_.noalias() = 0.25 * (Z_ * Z_);
        Qn_ = A2_;
        Qn_.noalias() += Q_ * Q_;
        lu_.compute(Q_);
        G_ = Qn_;
        Qn_.noalias() = lu_.solve(G_);
        for (std::size_t j = 0; j < dirs; ++j) {  // dA = (c/2) C_j, A = Z/2
            M_.noalias() = (0.25 * c) * (C_[j] * Z_);
            M_.noalias() += (0.25 * c) * (Z_ * C_[j]);
            M_.noalias() += dQ_[j] * Q_;
            M_.noalias() += Q_ * dQ_[j];
            M_.noalias() -= dQ_[j] * Qn_;
            dQ_[j].noalias() = lu_.solve(M_);
        }
        Q_ = Qn_;
        Z_ *= 2;
    }
}

void RealisationEvaluator::eval_lie_poisson(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                                            RealisationValues& v) const {
    const auto n = static_cast<Eigen::Index>(n_);
    form_L(p);
    if (operator_norm(L_) <= radius_) {
        const LieScratch s{v_prev_.data(), v_next_.data(), W_prev_.data(), W_next_.data(), power_.data(), tmp_.data()};
        // NOTE: so(3)* and e(3)* (n = 3, 6) get loops of fixed length, which the compiler unrolls: ~2x.
        switch (n) {
            case 3:
                lie_poisson_series<3>(b_, C_, L_.data(), x.data(), n, s, v.alpha.data(), v.alpha_x.data(),
                                      v.alpha_p.data());
                break;
            case 6:
                lie_poisson_series<6>(b_, C_, L_.data(), x.data(), n, s, v.alpha.data(), v.alpha_x.data(),
                                      v.alpha_p.data());
                break;
            default:
                lie_poisson_series<0>(b_, C_, L_.data(), x.data(), n, s, v.alpha.data(), v.alpha_x.data(),
                                      v.alpha_p.data());
        }
    } else {
        // g(L) = -L/2 + Q(L); d g(L) x / dp_j = -C_j x / 2 + dQ_j x
        coth_form(true);
        v.alpha_x = Q_;
        v.alpha_x.noalias() -= 0.5 * L_;
        v.alpha.noalias() = v.alpha_x * x;
        for (Eigen::Index j = 0; j < n; ++j) {
            v.alpha_p.col(j).noalias() = dQ_[static_cast<std::size_t>(j)] * x;
            v.alpha_p.col(j).noalias() -= 0.5 * (C_[static_cast<std::size_t>(j)] * x);
        }
    }
    // delta = beta - alpha = -2 sum_{m odd} B_m/m! L^m x = L(p) x: B_1 = -1/2 and B_3 = B_5 = ... = 0
    matvec<0>(L_.data(), x.data(), v.delta.data(), n);
    v.delta_x = L_;
    for (Eigen::Index j = 0; j < n; ++j)
        matvec<0>(C_[static_cast<std::size_t>(j)].data(), x.data(), v.delta_p.col(j).data(), n);
}

namespace {

// x and p at the so(3) form's three coordinates.
void gather_block(const int (&block)[3], const Eigen::VectorXd& x, const Eigen::VectorXd& p, double* x3, double* p3) {
    for (int i = 0; i < 3; ++i) x3[i] = x[block[i]], p3[i] = p[block[i]];
}

}  // namespace

// The so(3) closed form on its three coordinates (poisson/realisation_lanes.ipp, one lane), the others left alone,
// and delta's derivatives: delta = L(p) x, so delta_x = L(p) and delta_p e_j = C_j x.
void RealisationEvaluator::eval_rotation(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                                         RealisationValues& v) const {
    double x3[3], p3[3], alpha[3], delta[3], alpha_x[9], alpha_p[9], delta_x[9], delta_p[9];
    gather_block(block_, x, p, x3, p3);
    rotation_eval(x3, p3, alpha, delta, alpha_x, alpha_p, delta_x, delta_p);
    v.alpha = x;
    v.delta.setZero();
    v.alpha_x.setIdentity();
    for (auto* m : {&v.alpha_p, &v.delta_x, &v.delta_p}) m->setZero();
    for (int i = 0; i < 3; ++i) {
        v.alpha[block_[i]] = alpha[i], v.delta[block_[i]] = delta[i];
        for (int k = 0; k < 3; ++k) {
            v.alpha_x(block_[i], block_[k]) = alpha_x[i + 3 * k], v.alpha_p(block_[i], block_[k]) = alpha_p[i + 3 * k];
            v.delta_x(block_[i], block_[k]) = delta_x[i + 3 * k], v.delta_p(block_[i], block_[k]) = delta_p[i + 3 * k];
        }
    }
}

void RealisationEvaluator::check(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationCheck& c,
                                 bool with_delta) const {
    const auto n = static_cast<Eigen::Index>(n_);
    c.neglected = 0;
    switch (form_) {
        case Form::polynomial: {
            in_.head(n) = x;
            in_.tail(n) = p;
            values_map_.eval(in_.data(), out_.data());
            c.shift = out_.segment(0, n);
            c.alpha = x + c.shift;
            for (std::size_t o = n_; o < values_map_.num_outputs(); ++o)
                c.neglected = std::max(c.neglected, std::abs(out_[Eigen::Index(o)]));
            if (with_delta) delta_map_.eval(in_.data(), c.delta.data());
            in_ = in_.cwiseAbs();
            size_map_.eval(in_.data(), c.size.data());
            c.size += x.cwiseAbs();
            return;
        }
        case Form::lie_poisson: {
            form_L(p);
            const double norm = operator_norm(L_);
            if (norm <= radius_) {
                // alpha = sum_m b_m L^m x; every term is at most |b_m| |L|^m |x| in size (b_0 = 1: shift = alpha - x
                // sums the terms m >= 1), by Horner from the highest m down, L (b_1 x + L (b_2 x + ...)), each b_m
                // with its rounding (b_low_): the small terms first, and every coefficient to twice the digits. The
                // residual read here is what the Newton step drives to zero; b_2 = 1/12 rounded, or the terms added
                // to the large ones from m = 1 up, each rounded to their ulps, made it err the same way at every
                // step: sl(2)* at k = 4, dt = 1/5 drifted 2.3e-19 a step (docs/math.md 6)
                const std::size_t D = b_.size() - 1;
                v_prev_ = b_low_[D] * x;
                v_prev_ += b_[D] * x;
                for (std::size_t m = D; m-- > 1;) {
                    v_next_.noalias() = L_ * v_prev_;
                    v_next_ += b_low_[m] * x;
                    v_next_ += b_[m] * x;
                    v_prev_.swap(v_next_);
                }
                if (D > 0)
                    c.shift.noalias() = L_ * v_prev_;
                else
                    c.shift.setZero();
                double size = 1, power = 1;
                for (std::size_t m = 1; m <= D; ++m) {
                    power *= norm;
                    size += std::abs(b_[m]) * power;
                }
                c.alpha = x + c.shift;
                c.size.setConstant(size * x.head(Eigen::Index(moving_)).lpNorm<Eigen::Infinity>());
            } else {
                coth_form(false);
                G_ = Q_;
                G_.noalias() -= 0.5 * L_;
                c.size.noalias() = G_.cwiseAbs() * x.cwiseAbs();
                G_.diagonal().array() -= 1.0;  // shift = (g(L) - I) x
                c.shift.noalias() = G_ * x;
                c.alpha = x + c.shift;
            }
            c.size += x.cwiseAbs();
            c.delta.noalias() = L_ * x;
            return;
        }
        case Form::rotation: {  // the three coordinates', the others' alpha_w = x_w and delta_w = 0
            double x3[3], p3[3], alpha[3], delta[3], size[3], shift[3];
            gather_block(block_, x, p, x3, p3);
            rotation_check(x3, p3, alpha, delta, size, shift);
            c.alpha = x;
            c.size = x.cwiseAbs();
            c.delta.setZero();
            c.shift.setZero();
            for (int i = 0; i < 3; ++i) {
                const int b = block_[i];
                c.alpha[b] = alpha[i], c.delta[b] = delta[i], c.size[b] = size[i], c.shift[b] = shift[i];
            }
            return;
        }
        case Form::log_canonical:
            log_canonical_check(x.data(), p.data(), c.alpha.data(), with_delta ? c.delta.data() : nullptr,
                                c.size.data(), c.shift.data());
            return;
    }
}

void RealisationEvaluator::delta(const Eigen::VectorXd& x, const Eigen::VectorXd& p, Eigen::VectorXd& delta) const {
    const auto n = static_cast<Eigen::Index>(n_);
    switch (form_) {
        case Form::polynomial:
            in_.head(n) = x;
            in_.tail(n) = p;
            delta_map_.eval(in_.data(), delta.data());
            return;
        case Form::lie_poisson:
            form_L(p);
            delta.noalias() = L_ * x;
            return;
        case Form::rotation: {
            double x3[3], p3[3], d[3];
            gather_block(block_, x, p, x3, p3);
            rotation_delta(x3, p3, d);
            delta.setZero();
            for (int i = 0; i < 3; ++i) delta[block_[i]] = d[i];
            return;
        }
        case Form::log_canonical:
            log_canonical_delta(x.data(), p.data(), delta.data());
            return;
    }
}

}  // namespace pgi
