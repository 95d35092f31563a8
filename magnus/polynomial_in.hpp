#pragma once
// Whether a polynomial is a polynomial in given ones (H and the Casimirs, say), decided by exact linear
// algebra over Q on the monomial basis.
#include "series/poly.hpp"

#include <optional>
#include <vector>

namespace pgi {

/// Q (in a ring whose variables are `names`, one per generator) with P = Q(G_1, ..., G_r), searched among
/// the products G^a of weighted degree sum a_i deg G_i <= deg P; nullopt when P is not such a combination,
/// or when more than max_products products or max_monomials monomials would be needed (undecided).
/// Generators must be non-constant.
std::optional<Poly> as_polynomial_in(const Poly& P, const std::vector<Poly>& G, const std::vector<std::string>& names,
                                     std::size_t max_products = 300, std::size_t max_monomials = 20000);

}  // namespace pgi
