// RealisationEvaluator's evaluation on patterns: alpha, delta and their derivatives on the evaluator's fixed
// patterns, O(pattern) per evaluation (the log-canonical closed form, the compiled polynomial form), for the
// Newton path of large sparse systems; the log-canonical derivatives are written once here for both the
// dense blocks and the patterns. The Lie-Poisson forms are dense: they evaluate dense and gather.
#include "poisson/realisation_eval.hpp"

#include <algorithm>
#include <cmath>

namespace pgi {

// u_j = (1/2) sum_l a_lj x_l p_l; alpha_j = x_j e^{u_j}; delta_j = x_j (e^{-u_j} - e^{u_j}) = -2 x_j sinh u_j, and the
// derivatives on the structure's pattern: du_j/dx_l = a_lj p_l / 2, du_j/dp_l = a_lj x_l / 2. put(k, j, ...) receives
// entry k of a_pattern_ (column j), put.diagonal(j, ...) the terms of d/dx_j of alpha_j and delta_j.
template <class Put>
void RealisationEvaluator::log_canonical_derivatives(const Eigen::VectorXd& x, const Eigen::VectorXd& p, Eigen::VectorXd& alpha,
                                                     Eigen::VectorXd& delta, Put put) const {
    for (std::size_t j = 0; j < n_; ++j) {
        double u = 0;
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            u += a_values_[std::size_t(k)] * x[l] * p[l];
        }
        // one transcendental: e^u - 1 keeps sinh u accurate for small u
        const double em1 = std::expm1(0.5 * u), e = 1.0 + em1;
        const double s = -(em1 + em1 / e), c = -(e + 1.0 / e);  // -2 sinh u, -2 cosh u
        const auto J = static_cast<Eigen::Index>(j);
        alpha[J] = x[J] * e;
        delta[J] = x[J] * s;
        for (int k = a_pattern_.outer[j]; k < a_pattern_.outer[j + 1]; ++k) {
            const int l = a_pattern_.inner[std::size_t(k)];
            const double ux = 0.5 * a_values_[std::size_t(k)] * p[l], up = 0.5 * a_values_[std::size_t(k)] * x[l];
            put(std::size_t(k), J, Eigen::Index(l), x[J] * e * ux, x[J] * e * up, x[J] * c * ux, x[J] * c * up);
        }
        put.diagonal(J, e, s);
    }
}

namespace {

struct DensePut {
    RealisationValues& v;
    void operator()(std::size_t, Eigen::Index j, Eigen::Index l, double ax, double ap, double dx, double dp) const {
        v.alpha_x(j, l) = ax, v.alpha_p(j, l) = ap, v.delta_x(j, l) = dx, v.delta_p(j, l) = dp;
    }
    void diagonal(Eigen::Index j, double e, double s) const { v.alpha_x(j, j) += e, v.delta_x(j, j) += s; }
};

}  // namespace

void RealisationEvaluator::eval_log_canonical(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const {
    for (auto* m : {&v.alpha_x, &v.alpha_p, &v.delta_x, &v.delta_p}) m->setZero();
    log_canonical_derivatives(x, p, v.alpha, v.delta, DensePut{v});
}

SparseRealisationValues RealisationEvaluator::sparse_values() const {
    SparseRealisationValues v;
    v.alpha.setZero(static_cast<Eigen::Index>(n_));
    v.delta.setZero(static_cast<Eigen::Index>(n_));
    v.alpha_x.assign(pattern_x_.nonzeros(), 0.0);
    v.delta_x = v.alpha_x;
    v.alpha_p.assign(pattern_p_.nonzeros(), 0.0);
    v.delta_p = v.alpha_p;
    return v;
}

namespace {

struct SparsePut {
    SparseRealisationValues& v;
    const std::vector<int>& to_x;
    const std::vector<int>& to_p;
    const std::vector<int>& diagonal_x;
    void operator()(std::size_t k, Eigen::Index, Eigen::Index, double ax, double ap, double dx, double dp) const {
        const auto kx = static_cast<std::size_t>(to_x[k]), kp = static_cast<std::size_t>(to_p[k]);
        v.alpha_x[kx] = ax, v.delta_x[kx] = dx, v.alpha_p[kp] = ap, v.delta_p[kp] = dp;
    }
    void diagonal(Eigen::Index j, double e, double s) const {
        const auto k = static_cast<std::size_t>(diagonal_x[std::size_t(j)]);
        v.alpha_x[k] = e, v.delta_x[k] = s;  // a_jj = 0: the diagonal holds these terms only
    }
};

// The values of a dense block on a full pattern (column-major, as the dense block is stored).
void gather(const Eigen::MatrixXd& m, std::vector<double>& out) { std::copy(m.data(), m.data() + m.size(), out.begin()); }

}  // namespace

void RealisationEvaluator::eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, SparseRealisationValues& v) const {
    switch (form_) {
        case Form::log_canonical:
            log_canonical_derivatives(x, p, v.alpha, v.delta, SparsePut{v, a_to_x_, a_to_p_, diagonal_x_});
            return;
        case Form::lie_poisson:
        case Form::rotation:
            eval(x, p, dense_);
            v.alpha = dense_.alpha, v.delta = dense_.delta;
            gather(dense_.alpha_x, v.alpha_x), gather(dense_.delta_x, v.delta_x);
            gather(dense_.alpha_p, v.alpha_p), gather(dense_.delta_p, v.delta_p);
            return;
        case Form::polynomial: break;
    }
    const double* d = eval_polynomial(x, p, v.alpha, v.delta);
    const std::size_t nx = pattern_x_.nonzeros(), np = pattern_p_.nonzeros();
    std::copy(d, d + nx, v.alpha_x.begin());
    std::copy(d + nx, d + 2 * nx, v.delta_x.begin());
    std::copy(d + 2 * nx, d + 2 * nx + np, v.alpha_p.begin());
    std::copy(d + 2 * nx + np, d + 2 * nx + 2 * np, v.delta_p.begin());
}

}  // namespace pgi
