#include "poisson/detail/dense_algebra.hpp"

#include <type_traits>

namespace pgi {

namespace {

template <int N>
using Mat = Eigen::Matrix<double, N, N>;
template <int N>
using Vec = Eigen::Matrix<double, N, 1>;

// f(std::integral_constant<int, N>) with N = n for the fixed sizes, Eigen::Dynamic otherwise.
template <class F>
void with_dimension(Eigen::Index n, F&& f) {
    switch (n) {
        case 2:
            return f(std::integral_constant<int, 2>{});
        case 3:
            return f(std::integral_constant<int, 3>{});
        case 4:
            return f(std::integral_constant<int, 4>{});
        case 6:
            return f(std::integral_constant<int, 6>{});
        default:
            return f(std::integral_constant<int, Eigen::Dynamic>{});
    }
}

template <int N>
Eigen::Map<const Mat<N>> view(const Eigen::MatrixXd& m) {
    return {m.data(), m.rows(), m.cols()};
}
template <int N>
Eigen::Map<Mat<N>> view(Eigen::MatrixXd& m) {
    return {m.data(), m.rows(), m.cols()};
}
template <int N>
Eigen::Map<const Vec<N>> view(const Eigen::VectorXd& v) {
    return {v.data(), v.rows()};
}
template <int N>
Eigen::Map<Vec<N>> view(Eigen::VectorXd& v) {
    return {v.data(), v.rows()};
}

}  // namespace

DenseAlgebra::DenseAlgebra(std::size_t n) : n_(static_cast<Eigen::Index>(n)) {
    with_dimension(n_, [&](auto N) {
        if constexpr (N == Eigen::Dynamic)
            lu_.template emplace<Eigen::PartialPivLU<Eigen::MatrixXd>>(n_);
        else
            lu_.template emplace<LU<N>>();  // in place: no move of a fresh LU's unset storage (GCC warned of it)
    });
}

void DenseAlgebra::jacobian(const Eigen::MatrixXd& ax, const Eigen::MatrixXd& ap, const Eigen::MatrixXd& H,
                            Eigen::MatrixXd& J) const {
    with_dimension(n_, [&](auto N) {
        auto j = view<N>(J);
        j = view<N>(ax);
        j.noalias() += view<N>(ap) * view<N>(H);
    });
}

void DenseAlgebra::solve(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, Eigen::VectorXd& dx) {
    with_dimension(n_, [&](auto N) {
        if constexpr (N == Eigen::Dynamic) {
            auto& lu = std::get<Eigen::PartialPivLU<Eigen::MatrixXd>>(lu_);
            lu.compute(J);
            dx.noalias() = lu.solve(r);
        } else {
            auto& lu = std::get<LU<N>>(lu_);
            lu.compute(Mat<N>(view<N>(J)));
            const Vec<N> d = lu.solve(Vec<N>(view<N>(r)));
            view<N>(dx) = d;
        }
    });
}

void DenseAlgebra::solve_again(const Eigen::VectorXd& r, Eigen::VectorXd& dx) const {
    with_dimension(n_, [&](auto N) {
        if constexpr (N == Eigen::Dynamic) {
            dx.noalias() = std::get<Eigen::PartialPivLU<Eigen::MatrixXd>>(lu_).solve(r);
        } else {
            const Vec<N> d = std::get<LU<N>>(lu_).solve(Vec<N>(view<N>(r)));
            view<N>(dx) = d;
        }
    });
}

void DenseAlgebra::product(const Eigen::MatrixXd& H, const Eigen::VectorXd& v, Eigen::VectorXd& out) const {
    with_dimension(n_, [&](auto N) { view<N>(out).noalias() = view<N>(H) * view<N>(v); });
}

}  // namespace pgi
