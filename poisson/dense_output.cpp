#include "poisson/dense_output.hpp"

#include <algorithm>

namespace pgi {

std::vector<std::vector<Poly>> lie_derivatives(const PoissonStructure& pi, const Poly& H, std::size_t m) {
    const PhaseSpace& M = pi.phase_space();
    const std::vector<Poly> f = pi.hamiltonian_vector_field(H);
    std::vector<std::vector<Poly>> out;
    if (m == 0) return out;
    out.push_back(f);  // L_f x = f
    for (std::size_t j = 2; j <= m; ++j) {
        std::vector<Poly> next;
        for (const Poly& previous : out.back()) {
            Poly d(M.ring());  // L_f g = grad g . f
            for (std::size_t l = 0; l < M.dim(); ++l) d += derivative(previous, M.x(l)) * f[l];
            next.push_back(std::move(d));
        }
        out.push_back(std::move(next));
    }
    return out;
}

namespace {

// i! / (i - j)!: the j-th derivative of theta^i at theta = 1 (0 for j > i).
double falling(std::size_t i, std::size_t j) {
    if (j > i) return 0;
    double r = 1;
    for (std::size_t q = 0; q < j; ++q) r *= double(i - q);
    return r;
}

}  // namespace

DenseOutput DenseOutput::build(const PoissonStructure& pi, const Poly& H, std::size_t method_order) {
    DenseOutput d;
    const std::size_t n = pi.dim();
    d.m_ = std::max<std::size_t>(1, method_order / 2);
    std::vector<Poly> flat;
    for (auto& level : lie_derivatives(pi, H, d.m_))
        for (auto& p : level) flat.push_back(std::move(p));
    d.lie_ = CompiledMap::build(flat, pi.phase_space().coordinate_vars());
    // The conditions at theta = 1 on the coefficients of theta^(m+1) .. theta^(2m+1): a small,
    // well-conditioned integer matrix (its entries are falling factorials), inverted once.
    const std::size_t m = d.m_;
    Eigen::MatrixXd A(m + 1, m + 1);
    for (std::size_t j = 0; j <= m; ++j)
        for (std::size_t i = 0; i <= m; ++i) A(Eigen::Index(j), Eigen::Index(i)) = falling(m + 1 + i, j);
    d.high_ = A.fullPivLu().inverse();
    d.d0_.resize(Eigen::Index(n), Eigen::Index(m));
    d.d1_.resize(Eigen::Index(n), Eigen::Index(m));
    d.coeff_ = Eigen::MatrixXd::Zero(Eigen::Index(n), Eigen::Index(2 * m + 2));
    d.x0_ = Eigen::VectorXd::Zero(Eigen::Index(n));
    d.cached_x1_ = d.x0_;
    d.rhs_ = Eigen::VectorXd::Zero(Eigen::Index(m + 1));
    return d;
}

void DenseOutput::derivatives_at(const Eigen::VectorXd& x, Eigen::MatrixXd& d) const {
    lie_.eval(x.data(), d.data());  // column-major n x m: output j-major, component-minor
}

void DenseOutput::fit(const Eigen::VectorXd& x0, const Eigen::VectorXd& x1, double dt) {
    if (cached_ && x0 == cached_x1_)
        d0_.swap(d1_);
    else
        derivatives_at(x0, d0_);
    derivatives_at(x1, d1_);
    cached_x1_ = x1;
    cached_ = true;
    x0_ = x0;
    const std::size_t m = m_;
    for (Eigen::Index c = 0; c < x0.size(); ++c) {
        // low coefficients from x0's Taylor data: c_j = dt^j x^(j)(x0) / j!, relative to x0 (c_0 = 0)
        coeff_(c, 0) = 0;
        double scale = 1;
        for (std::size_t j = 1; j <= m; ++j) {
            scale *= dt / double(j);
            coeff_(c, Eigen::Index(j)) = scale * d0_(c, Eigen::Index(j - 1));
        }
        // conditions at theta = 1 (value x1 - x0, derivatives dt^j x^(j)(x1)) less the low part's share
        double power = 1;
        for (std::size_t j = 0; j <= m; ++j) {
            double b = j == 0 ? x1(c) - x0(c) : (power *= dt) * d1_(c, Eigen::Index(j - 1));
            for (std::size_t i = j; i <= m; ++i) b -= falling(i, j) * coeff_(c, Eigen::Index(i));
            rhs_(Eigen::Index(j)) = b;
        }
        for (std::size_t i = 0; i <= m; ++i) coeff_(c, Eigen::Index(m + 1 + i)) = high_.row(Eigen::Index(i)).dot(rhs_);
    }
}

void DenseOutput::eval(double theta, double* out) const {
    const Eigen::Index top = coeff_.cols() - 1;
    for (Eigen::Index c = 0; c < coeff_.rows(); ++c) {
        double v = coeff_(c, top);
        for (Eigen::Index i = top - 1; i >= 0; --i) v = v * theta + coeff_(c, i);
        out[c] = x0_(c) + v;
    }
}

void DenseOutput::eval_derivative(double theta, double* out) const {
    const Eigen::Index top = coeff_.cols() - 1;
    for (Eigen::Index c = 0; c < coeff_.rows(); ++c) {
        double v = double(top) * coeff_(c, top);
        for (Eigen::Index i = top - 1; i >= 1; --i) v = v * theta + double(i) * coeff_(c, i);
        out[c] = v;
    }
}

}  // namespace pgi
