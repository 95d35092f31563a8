#pragma once
// Composition of polynomials with truncated series: f(images) + O(e^N), all at once or one order at a time.
#include "series/series.hpp"

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <utility>
#include <vector>

namespace pgi {

/// The exponents of the substituted variables in a monomial, as (variable, exponent > 0) by increasing
/// variable: O(variables held), where a dense exponent vector costs O(ring size) (2n on a lattice of n sites).
using SparseExponents = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

/// Polynomials f_0..f_{r-1} composed with series images one order at a time: [e^m] f_i(images) reads the
/// images' coefficients through e^m only. A recursion whose next image coefficient is made from the lower
/// coefficients of a composition (the Hamilton-Jacobi terms, docs/math.md 5; the radial realisation, 4;
/// the inverse of a near-identity map) completes the images as it goes, and each coefficient of each
/// product of images is formed once, however many orders are asked for: recomposing from scratch at
/// every order forms the low coefficients again at each one.
class ComposeByOrder {
public:
    /// images[v]: the series replacing variable v, of order N, or none to keep v (it counts as degree 0).
    /// Throws std::invalid_argument unless there is one (optional) image per variable of the fs' ring,
    /// each of order N.
    ComposeByOrder(const std::vector<Poly>& fs, std::vector<std::optional<Series>> images, std::size_t N);
    /// No polynomial yet (append adds them), in ring's variables.
    ComposeByOrder(RingPtr ring, std::vector<std::optional<Series>> images, std::size_t N);

    /// Adds f as the next polynomial (its index is returned) for a recursion that makes its polynomials as it
    /// goes; it shares the products formed so far. Throws std::invalid_argument if f is of another ring.
    std::size_t append(const Poly& f);

    std::size_t order() const { return N_; }
    /// Sets coefficient m of the image of variable v. Throws std::logic_error if an order >= m has
    /// already been composed (it read the old coefficient), std::invalid_argument if v has no image or
    /// m >= N.
    void set_image(std::size_t v, std::size_t m, Poly c);
    /// [e^m] f_i(images), m < N, from the images' coefficients 0..m as they are now.
    Poly coefficient(std::size_t i, std::size_t m);

private:
    // A product prod_v images[v]^{e_v} of the images, formed coefficient by coefficient on demand from the
    // product with one factor fewer (lower: its index; factor: the variable of the missing factor). Index 0
    // is the empty product 1; a single factor is read from its image, not copied.
    struct Product {
        std::uint32_t factor = 0, lower = 0;
        std::vector<Poly> c;  // reserved to N once used: references to its coefficients stay valid
    };
    // One term of f_i by its substituted part: kept * products_[product], kept over the kept variables (a
    // constant kept is used as a scalar).
    struct Group {
        std::uint32_t product;
        Poly kept;
        std::optional<Rational> scalar;
    };
    std::uint32_t product_index(const SparseExponents& e);
    // Coefficient m of product p, formed (with the ones below it) on first use.
    const Poly& product_coefficient(std::uint32_t p, std::size_t m);
    void extend_product(std::uint32_t q, std::size_t m);

    RingPtr ring_;
    std::optional<Poly> one_, zero_;  // the empty product's coefficients
    std::size_t N_;
    std::vector<std::optional<Series>> images_;
    std::vector<std::vector<Group>> groups_;  // f_i = sum over groups_[i]
    std::vector<Product> products_;  // only grows (append); product_coefficient's references into each c stay valid
    std::map<SparseExponents, std::uint32_t> product_of_;  // products_'s index by exponents
    long composed_through_ = -1;                           // the highest order asked for so far
};

/// f with the variable v replaced by images[v] where images[v] is set, + O(e^N); the other variables
/// stay as they are and count as degree 0. Every image must have order N.
Series compose(const Poly& f, const std::vector<std::optional<Series>>& images, std::size_t N);
/// The same for several polynomials at once, sharing the products of the images (all in one ring).
std::vector<Series> compose(const std::vector<Poly>& fs, const std::vector<std::optional<Series>>& images,
                            std::size_t N);
/// sum_m e^m f_m(images) + O(e^N): a series whose coefficients are themselves composed (images of order N).
std::vector<Series> compose(const std::vector<Series>& fs, const std::vector<std::optional<Series>>& images,
                            std::size_t N);
/// v with (id + u) o (id + v) = id + O(e^N), for u = O(e) given on the listed variables (u[i] displaces
/// variable vars[i]; all of order N), order by order (v = -u(id + v): each order reads only lower ones). If
/// enough is given, it sees v after each sweep (v exact to its order, s + 1 after sweep s) and may end
/// the computation early by returning true: the result is then of that lower order. Throws
/// std::invalid_argument when a u[i] is not O(e) or not of order N.
std::vector<Series> inverse_near_identity(const std::vector<Series>& u, const std::vector<std::size_t>& vars,
                                          std::size_t N,
                                          const std::function<bool(const std::vector<Series>&)>& enough = {});

}  // namespace pgi
