#pragma once
// The numeric values of what a Scheme knows exactly: the vector field pi grad H, pi, H, the Casimirs and the
// modified Hamiltonian, at m states given as the rows of X (m x n, row-major; one state x is the 1 x n
// x.transpose()). Each comes from the scheme's compiled maps (Scheme::vector_field_map(), ...), compiled once per
// scheme; a row's values are the same bits whatever m and its place among the rows (CompiledMap::eval_batch).
// Thread-safe. Each throws InputError("x", ...) for X without n columns or with a value that is not finite,
// before any work. parameters: the values of the scheme's parameters (1 value, or one per row; the defaults for those
// not given), InputError as Scheme::parameter_rows throws it.
#include "scheme/ensemble.hpp"
#include "scheme/scheme.hpp"

#include <Eigen/Dense>

#include <cstddef>

namespace pgi {

/// The last power of dt of the modified Hamiltonian's evaluator, as `pgi modified --upto`.
constexpr std::size_t max_modified_upto = 64;

/// pi(x) grad H(x), the time derivative of the flow (units of x per unit of t): m x n.
RowMatrix vector_field(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X,
                       const ParameterValues& parameters = {});
/// pi(x) row by row: m x n^2, pi_ik(x_j) at (j, i n + k); skew-symmetric and zero on the diagonal by construction.
RowMatrix poisson_matrices(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X,
                           const ParameterValues& parameters = {});
/// H(x): m values.
Eigen::VectorXd hamiltonian_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X,
                                   const ParameterValues& parameters = {});
/// The scheme's Casimirs at each row, in their order: m x c.
RowMatrix casimir_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X,
                         const ParameterValues& parameters = {});
/// H_0 + dt H_1 + ... + dt^upto H_upto, the modified Hamiltonian the method of step dt conserves, summed by Horner
/// in dt: m values. InputError for dt not positive and finite ("dt") or upto above max_modified_upto ("upto");
/// throws what Scheme::modified_hamiltonian throws (an invalid scheme) the first time an upto is asked for.
Eigen::VectorXd modified_hamiltonian_values(const Scheme& scheme, const Eigen::Ref<const RowMatrix>& X, double dt,
                                            std::size_t upto, const ParameterValues& parameters = {});

}  // namespace pgi
