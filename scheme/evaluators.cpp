#include "scheme/evaluators.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace pgi {

namespace {

// Rows turned to columns at a time: the block's inputs and outputs stay in cache whatever m is.
constexpr std::size_t block_rows = 256;

// The extended states (x, w) of the rows of X and the parameter values, after the checks: InputError("x") unless X has
// one column per coordinate and every value is finite, InputError("parameters...") as Scheme::parameter_rows says.
RowMatrix states(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X, const ParameterValues& parameters) {
    const std::size_t n = scheme.dim();
    if (std::size_t(X.cols()) != n)
        throw InputError(
            "x", "must have " + std::to_string(n) + " columns (one per coordinate), got " + std::to_string(X.cols()));
    for (Eigen::Index j = 0; j < X.rows(); ++j)
        if (!X.row(j).allFinite()) throw InputError("x", "row " + std::to_string(j) + " is not finite");
    return scheme.extended_states(X, scheme.parameter_rows(parameters, std::size_t(X.rows())));
}

// f at every row of X, a block of rows at a time through eval_batch; emit(j, y, stride) is given
// row j's outputs, output o at y[o stride].
template <class Emit>
void for_each_row(const CompiledMap& f, const Eigen::Ref<const RowMatrix>& X, Emit emit) {
    const std::size_t m = std::size_t(X.rows()), n = std::size_t(X.cols());
    if (f.num_outputs() == 0) return;
    std::vector<double> in(n * std::min(m, block_rows)), out(f.num_outputs() * std::min(m, block_rows)), scratch;
    for (std::size_t start = 0; start < m; start += block_rows) {
        const std::size_t b = std::min(block_rows, m - start);
        for (std::size_t j = 0; j < b; ++j)
            for (std::size_t v = 0; v < n; ++v) in[v * b + j] = X(Eigen::Index(start + j), Eigen::Index(v));
        f.eval_batch(in.data(), out.data(), b, scratch);
        for (std::size_t j = 0; j < b; ++j) emit(Eigen::Index(start + j), out.data() + j, b);
    }
}

}  // namespace

RowMatrix vector_field(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X_in,
                       const ParameterValues& parameters) {
    const RowMatrix X = states(scheme, X_in, parameters);
    RowMatrix F(X.rows(), X_in.cols());
    for_each_row(scheme.vector_field_map(), X, [&](Eigen::Index j, const double* y, std::size_t stride) {
        for (Eigen::Index i = 0; i < F.cols(); ++i) F(j, i) = y[std::size_t(i) * stride];
    });
    return F;
}

RowMatrix poisson_matrices(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X_in,
                           const ParameterValues& parameters) {
    const RowMatrix X = states(scheme, X_in, parameters);
    const CompiledBrackets& b = scheme.brackets_map();
    const std::size_t n = scheme.dim();  // the parameters' rows and columns of pi are zero
    RowMatrix P = RowMatrix::Zero(X.rows(), Eigen::Index(n * n));
    for_each_row(b.map, X, [&](Eigen::Index j, const double* y, std::size_t stride) {
        for (std::size_t e = 0; e < b.entries.size(); ++e) {
            const auto [i, k] = b.entries[e];
            P(j, Eigen::Index(i * n + k)) = y[e * stride];
            P(j, Eigen::Index(k * n + i)) = -y[e * stride];
        }
    });
    return P;
}

Eigen::VectorXd hamiltonian_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X_in,
                                   const ParameterValues& parameters) {
    const RowMatrix X = states(scheme, X_in, parameters);
    Eigen::VectorXd H(X.rows());
    for_each_row(scheme.invariants_map(), X, [&](Eigen::Index j, const double* y, std::size_t) { H[j] = y[0]; });
    return H;
}

RowMatrix casimir_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X_in,
                         const ParameterValues& parameters) {
    const RowMatrix X = states(scheme, X_in, parameters);
    RowMatrix C(X.rows(), Eigen::Index(scheme.casimirs().size()));
    for_each_row(scheme.invariants_map(), X, [&](Eigen::Index j, const double* y, std::size_t stride) {
        for (Eigen::Index c = 0; c < C.cols(); ++c) C(j, c) = y[std::size_t(c + 1) * stride];  // output 0 is H
    });
    return C;
}

Eigen::VectorXd modified_hamiltonian_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X_in, double dt,
                                            std::size_t upto, const ParameterValues& parameters) {
    if (!(dt > 0) || !std::isfinite(dt)) throw InputError("dt", "must be positive and finite");
    if (upto > max_modified_upto) throw InputError("upto", "must be at most " + std::to_string(max_modified_upto));
    const RowMatrix X = states(scheme, X_in, parameters);  // before the exact phase (the first call for an upto)
    Eigen::VectorXd Ht(X.rows());
    for_each_row(scheme.modified_hamiltonian_map(upto), X, [&](Eigen::Index j, const double* y, std::size_t stride) {
        double v = y[upto * stride];
        for (std::size_t o = upto; o-- > 0;) v = v * dt + y[o * stride];
        Ht[j] = v;
    });
    return Ht;
}

}  // namespace pgi
