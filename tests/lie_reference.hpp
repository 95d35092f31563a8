#pragma once
// Long double references for the Lie-Poisson realisation and the step it defines (tests only).
#include "poisson/hamilton_jacobi.hpp"
#include "poisson/realisation_eval.hpp"

#include <Eigen/Dense>

#include <vector>

namespace pgi::test {

// A reference for alpha = g(L(p)) x, g(z) = z / (e^z - 1), in long double: the Taylor coefficients c_m of g
// summed to degree 3000 (for spectral radii below 0.97 * 2 pi the tail is under 1e-39), the structure matrices taken
// from the evaluator's own delta_p (C_j x) and delta_x (L) being linear in x and p.
struct LongDoubleLie {
    std::vector<Eigen::Matrix<long double, -1, -1>> C;
    std::vector<long double> c;
    explicit LongDoubleLie(const RealisationEvaluator& e, Eigen::Index n) {
        RealisationValues v(static_cast<std::size_t>(n));
        for (Eigen::Index j = 0; j < n; ++j) {
            C.emplace_back(n, n);
            for (Eigen::Index k = 0; k < n; ++k) {  // column k of C_j = d(C_j x)/dx_k: delta_p column j at x = e_k
                Eigen::VectorXd x = Eigen::VectorXd::Unit(n, k), p = Eigen::VectorXd::Zero(n);
                e.eval(x, p, v);
                C.back().col(k) = v.delta_p.col(j).cast<long double>();
            }
        }
        // c_m = B_m / m!: the recurrence of g (e^z - 1) / z = 1 for m <= 30, where it is accurate; beyond,
        // c_2j = (-1)^(j+1) 2 zeta(2j) / (2 pi)^2j with zeta summed directly (its tail past n = 20 is < 1e-39)
        std::vector<long double> inv_fact{1.0L};
        for (int m = 1; m <= 32; ++m) inv_fact.push_back(inv_fact.back() / m);
        c.push_back(1.0L);
        for (std::size_t m = 1; m <= 30; ++m) {
            long double s = 0;
            for (std::size_t j = 0; j < m; ++j) s -= c[j] * inv_fact[m - j + 1];
            c.push_back(s);
        }
        const long double two_pi = 6.283185307179586476925286766559L;
        for (std::size_t m = 31; m <= 3000; ++m) {
            if (m % 2) {
                c.push_back(0.0L);
                continue;
            }
            long double zeta = 0;
            for (int k = 20; k >= 1; --k) zeta += std::pow(static_cast<long double>(k), -static_cast<long double>(m));
            c.push_back((m % 4 == 0 ? -2.0L : 2.0L) * zeta * std::pow(two_pi, -static_cast<long double>(m)));
        }
    }
    Eigen::Matrix<long double, -1, 1> alpha(const Eigen::Matrix<long double, -1, 1>& x,
                                            const Eigen::Matrix<long double, -1, 1>& p) const {
        const auto n = x.size();
        Eigen::Matrix<long double, -1, -1> L = Eigen::Matrix<long double, -1, -1>::Zero(n, n);
        for (Eigen::Index j = 0; j < n; ++j) L += p[j] * C[static_cast<std::size_t>(j)];
        Eigen::Matrix<long double, -1, 1> v = x, sum = v;
        for (std::size_t m = 1; m < c.size(); ++m) {
            v = L * v;
            sum += c[m] * v;
        }
        return sum;
    }
};

using VectorLD = Eigen::Matrix<long double, -1, 1>;

/// One step of order k and size dt from x on a Lie-Poisson structure, in long double: S_1..S_k exact (from the
/// exact Lie-Poisson realisation), grad S_dt by the compiled map's long double evaluation, alpha by
/// LongDoubleLie, xb by Newton from xb0 (the double solution: the same branch of the implicit equation) with
/// a central-difference Jacobian (h = 1e-7 |x|: its error ~1e-14 slows convergence to a factor 1e-14 per
/// iteration, still to the long double floor), x_new = x + L(p) xb (delta = beta - alpha = L x).
inline VectorLD lie_step_reference(const PoissonStructure& pi, const Poly& H, std::size_t k, double dt,
                                   const Eigen::VectorXd& x, const Eigen::VectorXd& xb0, double& spectral_radius) {
    const PhaseSpace& M = pi.phase_space();
    const auto n = x.size();
    const auto S = hamilton_jacobi_terms(M, lie_poisson_realisation(pi, k + 1), H, k);
    const Poly S_dt = sum_powers(S, Rational::from_double(dt), 1);
    std::vector<Poly> grad;
    for (std::size_t l = 0; l < M.dim(); ++l) grad.push_back(derivative(S_dt, M.x(l)));
    const CompiledMap g = CompiledMap::build(grad, M.coordinate_vars());
    const LongDoubleLie lie(RealisationEvaluator::lie_poisson(pi, 2), n);
    std::vector<long double> scratch;
    const auto p_of = [&](const VectorLD& xb) {
        VectorLD p(n);
        g.eval(xb.data(), p.data(), scratch);
        return p;
    };
    const VectorLD x_ld = x.cast<long double>();
    const auto F = [&](const VectorLD& xb) -> VectorLD { return lie.alpha(xb, p_of(xb)) - x_ld; };
    VectorLD xb = xb0.cast<long double>();
    for (int it = 0; it < 20; ++it) {
        const long double h = 1e-7L * std::max(1.0L, xb.cwiseAbs().maxCoeff());
        Eigen::Matrix<long double, -1, -1> J(n, n);
        for (Eigen::Index j = 0; j < n; ++j) {
            VectorLD a = xb, b = xb;
            a[j] += h, b[j] -= h;
            J.col(j) = (F(a) - F(b)) / (2 * h);
        }
        const VectorLD dx = J.partialPivLu().solve(F(xb));
        xb -= dx;
        if (dx.cwiseAbs().maxCoeff() <= 1e-19L * x_ld.cwiseAbs().maxCoeff()) break;
    }
    const VectorLD p = p_of(xb);
    Eigen::Matrix<long double, -1, -1> L = Eigen::Matrix<long double, -1, -1>::Zero(n, n);
    for (Eigen::Index j = 0; j < n; ++j) L += p[j] * lie.C[static_cast<std::size_t>(j)];
    const Eigen::MatrixXd Ld = L.cast<double>();
    spectral_radius = Ld.eigenvalues().cwiseAbs().maxCoeff();  // the reference's series needs it below ~0.9 * 2 pi
    return x_ld + L * xb;
}

/// grad S_dt at xb (double), S of order k from the exact Lie-Poisson realisation.
inline Eigen::VectorXd lie_p(const PoissonStructure& pi, const Poly& H, std::size_t k, double dt,
                             const Eigen::VectorXd& xb) {
    const PhaseSpace& M = pi.phase_space();
    const auto S = hamilton_jacobi_terms(M, lie_poisson_realisation(pi, k + 1), H, k);
    const Poly S_dt = sum_powers(S, Rational::from_double(dt), 1);
    std::vector<Poly> grad;
    for (std::size_t l = 0; l < M.dim(); ++l) grad.push_back(derivative(S_dt, M.x(l)));
    Eigen::VectorXd p(xb.size());
    CompiledMap::build(grad, M.coordinate_vars()).eval(xb.data(), p.data());
    return p;
}

}  // namespace pgi::test
