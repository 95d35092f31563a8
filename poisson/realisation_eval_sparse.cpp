// RealisationEvaluator's evaluation on patterns: alpha, delta and their derivatives on the evaluator's fixed
// patterns, O(pattern) per evaluation (the log-canonical closed form, the compiled polynomial form), for the
// Newton path of large sparse systems; the log-canonical derivatives are written once here for both the
// dense blocks and the patterns. The Lie-Poisson forms are dense: they evaluate dense and gather.
#include "poisson/log_canonical.ipp"
#include "poisson/realisation_eval.hpp"

#include <algorithm>
#include <cmath>

namespace pgi {

namespace {

struct DensePut {
    RealisationValues& v;
    void operator()(std::size_t, Eigen::Index j, Eigen::Index l, double ax, double ap, double dx, double dp) const {
        v.alpha_x(j, l) = ax, v.alpha_p(j, l) = ap, v.delta_x(j, l) = dx, v.delta_p(j, l) = dp;
    }
    void diagonal(Eigen::Index j, double e, double s) const { v.alpha_x(j, j) += e, v.delta_x(j, j) += s; }
};

}  // namespace

void RealisationEvaluator::eval_log_canonical(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                                              RealisationValues& v) const {
    for (auto* m : {&v.alpha_x, &v.alpha_p, &v.delta_x, &v.delta_p}) m->setZero();
    log_canonical_derivatives(x.data(), p.data(), v.alpha.data(), v.delta.data(), DensePut{v});
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
void gather(const Eigen::MatrixXd& m, std::vector<double>& out) {
    std::copy(m.data(), m.data() + m.size(), out.begin());
}

}  // namespace

void RealisationEvaluator::eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, SparseRealisationValues& v) const {
    switch (form_) {
        case Form::log_canonical:
            log_canonical_derivatives(x.data(), p.data(), v.alpha.data(), v.delta.data(),
                                      SparsePut{v, a_to_x_, a_to_p_, diagonal_x_});
            return;
        case Form::lie_poisson:
        case Form::rotation:
            eval(x, p, dense_);
            v.alpha = dense_.alpha, v.delta = dense_.delta;
            gather(dense_.alpha_x, v.alpha_x), gather(dense_.delta_x, v.delta_x);
            gather(dense_.alpha_p, v.alpha_p), gather(dense_.delta_p, v.delta_p);
            return;
        case Form::polynomial:
            break;
    }
    const double* d = eval_polynomial(x, p, v.alpha, v.delta);
    const std::size_t nx = pattern_x_.nonzeros(), np = pattern_p_.nonzeros();
    std::copy(d, d + nx, v.alpha_x.begin());
    std::copy(d + nx, d + 2 * nx, v.delta_x.begin());
    std::copy(d + 2 * nx, d + 2 * nx + np, v.alpha_p.begin());
    std::copy(d + 2 * nx + np, d + 2 * nx + 2 * np, v.delta_p.begin());
}

}  // namespace pgi
