#pragma once
// RealisationEvaluator: alpha, beta - alpha and their first derivatives at a point (x, p), in double.
#include "poisson/realisation.hpp"
#include "poisson/sparse_pattern.hpp"
#include "series/compile.hpp"

#include <Eigen/Dense>

namespace pgi {

/// What one evaluation produces; every block is sized once by the evaluator and reused.
struct RealisationValues {
    Eigen::VectorXd alpha, delta;                        // alpha(x, p) and delta = beta - alpha
    Eigen::MatrixXd alpha_x, alpha_p, delta_x, delta_p;  // d/dx and d/dp of each (row i: component i)
    explicit RealisationValues(std::size_t n = 0);
};

/// The same on the evaluator's fixed patterns (pattern_x() for alpha_x and delta_x, pattern_p() for alpha_p
/// and delta_p, values in pattern order): what the sparse Newton path reads, O(pattern) per evaluation.
struct SparseRealisationValues {
    Eigen::VectorXd alpha, delta;
    std::vector<double> alpha_x, delta_x, alpha_p, delta_p;
};

/// What the step's acceptance test reads at the solution (no derivatives): alpha, delta, the size of
/// the terms summed into each alpha_i (an upper bound, for a round-off tolerance), and the size of the
/// first neglected p-degrees of a truncated realisation (0 where the evaluation is exact to round-off).
/// shift = alpha - x summed as its own expression (the p-dependent terms, without x): the step's residual
/// (x_b - x) + shift then resolves what alpha, rounded to the ulps of x, cannot (docs/math.md 6, Casimirs).
struct RealisationCheck {
    Eigen::VectorXd alpha, delta, size, shift;
    double neglected = 0;  // max_i |A_{D+1,i}| + |A_{D+2,i}| at (x, p)
    explicit RealisationCheck(std::size_t n = 0);
};

/// What the Newton step reads of one evaluation, over lanes (poisson/lanes.hpp: T = double for one state, a
/// Pack for several) at a fixed dimension N: alpha, delta and their derivatives (column-major N x N); for the
/// log-canonical form also its exponents u_j and e^{u_j/2} - 1 there, from which check_lanes near that point takes
/// its own exponentials (docs/math.md 3).
template <int N, class T>
struct LaneRealisation {
    T alpha[N], delta[N], alpha_x[N * N], alpha_p[N * N], delta_x[N * N], delta_p[N * N], exponent[N], em1[N];
};
/// RealisationCheck over lanes.
template <int N, class T>
struct LaneCheck {
    T alpha[N], delta[N], size[N], shift[N], neglected;
};
/// The compiled polynomial form's inputs and outputs over lanes, and CompiledMap::eval_batch's scratch.
template <class T>
struct LaneMapScratch {
    std::vector<T> in, out;
    std::vector<double> map;
};

/// f with every coefficient replaced by its absolute value: at (|x|, |p|) the sum of the sizes of its terms.
Poly absolute_coefficients(const Poly& f);

/// One of: a compiled polynomial realisation (any class, truncated at p-degree D); the log-canonical
/// closed form alpha_j = x_j exp(u_j), u_j = (1/2) sum_i a_ij x_i p_i, exact in floating point; or the
/// Lie-Poisson form alpha = g(L(p)) x, g(z) = z / (e^z - 1) (docs/math.md 3): the series sum_{m<=D} B_m/m! L^m x
/// by matrix-vector products while |L|_inf is below the radius where its tail is under round-off, and
/// beyond, g(L) = -L/2 + Q(L) with Q(z) = (z/2) coth(z/2) by scaling and squaring (Q(2z) = (a^2 + Q(z)^2) /
/// Q(z), a = z/2), its p-derivatives by differentiating the same recursion: exact to round-off for every
/// L whose eigenvalues stay off the poles 2 pi i k (k != 0) of g.
/// delta = beta - alpha is computed as its own expression (-2 x_j sinh u_j; L(p) x, since the odd
/// Bernoulli numbers past B_1 vanish; or the odd part of the series), so small steps do not cancel.
class RealisationEvaluator {
public:
    RealisationEvaluator() = default;
    /// neglected: the parts of alpha of the first p-degrees past r.degree (any number of polynomials,
    /// typically A_{D+1,i} and A_{D+2,i}), evaluated by check() as the truncation's size.
    static RealisationEvaluator polynomial(const PoissonStructure& pi, const Realisation& r,
                                           const std::vector<Poly>& neglected = {});
    static RealisationEvaluator log_canonical(const PoissonStructure& pi);
    static RealisationEvaluator lie_poisson(const PoissonStructure& pi, std::size_t D);
    /// so(3)*-type structures (linear, exactly three coordinates with non-zero rows, every C_j skew on them and zero
    /// elsewhere, so L(p) is skew and L^3 = -s L): the series summed in closed form on those three, alpha = x - L x / 2
    /// + h(s) L^2 x, exact in floating point; the other coordinates (Casimirs with zero rows, such as a scheme's
    /// parameters) are left alone exactly: alpha_w = x_w, delta_w = 0, and no p_w enters.
    static bool has_rotation_form(const PoissonStructure& pi);
    static RealisationEvaluator rotation(const PoissonStructure& pi);

    /// One evaluation's cost in multiply-adds, roughly (transcendentals counted as 20): for cost models;
    /// sparse: of the evaluation on the patterns.
    std::size_t cost(bool sparse = false) const;
    /// The compiled maps of the polynomial form (none for the closed forms): for native code.
    std::vector<CompiledMap*> compiled_maps();

    /// Writes every block of v. Allocates nothing.
    void eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    /// Where the derivatives by x (alpha_x, delta_x) and by p (alpha_p, delta_p) can be non-zero: the
    /// structure's pattern (and the diagonal) for the log-canonical form, the variables each compiled component
    /// holds for the polynomial form, every entry for the Lie-Poisson forms.
    const SparsePattern& pattern_x() const { return pattern_x_; }
    const SparsePattern& pattern_p() const { return pattern_p_; }
    /// Values sized for eval(x, p, SparseRealisationValues&).
    SparseRealisationValues sparse_values() const;
    /// Writes every block of v on the patterns (poisson/realisation_eval_sparse.cpp). Allocates nothing.
    void eval(const Eigen::VectorXd& x, const Eigen::VectorXd& p, SparseRealisationValues& v) const;
    /// Writes every field of c (alpha and delta as eval writes them); without with_delta every field but delta, which
    /// the polynomial and log-canonical forms then do not compute (the Newton step takes delta once, at its end).
    /// Allocates nothing.
    void check(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationCheck& c, bool with_delta = true) const;
    /// delta alone, as check writes it: the increment after the Newton step's last (polishing) round.
    void delta(const Eigen::VectorXd& x, const Eigen::VectorXd& p, Eigen::VectorXd& delta) const;
    /// Whether eval_lanes and check_lanes serve this form: the so(3) and log-canonical closed forms and the compiled
    /// polynomial one (the Lie-Poisson series has none yet).
    bool has_lane_form() const {
        return form_ == Form::rotation || form_ == Form::log_canonical || form_ == Form::polynomial;
    }
    /// The leading coordinates eval_lanes, check_lanes and delta_lanes act on (their N): for the so(3) form its three
    /// coordinates when they lead the others (which it leaves alone: alpha_w = x_w, delta_w = 0); for the
    /// log-canonical and polynomial forms every coordinate but the trailing ones they leave alone and no other
    /// component reads (a scheme's parameters).
    std::size_t leading_dimension() const {
        return form_ == Form::rotation && block_[0] == 0 && block_[1] == 1 && block_[2] == 2 ? 3 : lead_;
    }
    /// eval's alpha, delta, alpha_x and alpha_p (and check's values) on N coordinates (all, or leading_dimension()
    /// of them), for lanes::width states at once or one (poisson/realisation_lanes.ipp): each lane's numbers are those
    /// of the double instantiation on it, bit for bit. Allocates nothing with s from lane_scratch<T>(). Requires
    /// has_lane_form().
    template <class T>
    LaneMapScratch<T> lane_scratch() const;
    template <int N, class T>
    void eval_lanes(const T* x, const T* p, LaneRealisation<N, T>& v, LaneMapScratch<T>& s) const;
    template <int N, class T>
    void check_lanes(const T* x, const T* p, LaneCheck<N, T>& c, LaneMapScratch<T>& s,
                     const LaneRealisation<N, T>* near = nullptr, bool with_delta = true) const;
    /// check_lanes' delta alone.
    template <int N, class T>
    void delta_lanes(const T* x, const T* p, T* delta, LaneMapScratch<T>& s,
                     const LaneRealisation<N, T>* near = nullptr) const;
    /// Lie-Poisson: the largest |L(p)|_inf at which the truncated series is used (beyond: scaling and squaring).
    double series_radius() const { return radius_; }
    /// Lie-Poisson: |L(p)|_inf, and the smallest D in [D_min, D_max] whose series is used at that norm (D_max if none).
    double operator_norm_at(const Eigen::VectorXd& p) const;
    static std::size_t series_degree_for(double norm, std::size_t D_min, std::size_t D_max);

private:
    enum class Form { polynomial, log_canonical, lie_poisson, rotation };
    void eval_log_canonical(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    // (poisson/log_canonical.ipp) on the first `count` coordinates, all by default
    template <class T, class Put>
    void log_canonical_derivatives(const T* x, const T* p, T* alpha, T* delta, Put put, T* exponent = nullptr,
                                   T* em1 = nullptr, std::size_t count = SIZE_MAX) const;
    template <class T>
    void log_canonical_delta(const T* x, const T* p, T* delta, const T* exponent_near = nullptr,
                             const T* em1_near = nullptr, std::size_t count = SIZE_MAX) const;
    template <class T>
    void log_canonical_check(const T* x, const T* p, T* alpha, T* delta, T* size, T* shift,  // (delta may be null)
                             const T* exponent_near = nullptr, const T* em1_near = nullptr,
                             std::size_t count = SIZE_MAX) const;
    void eval_lie_poisson(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    void eval_rotation(const Eigen::VectorXd& x, const Eigen::VectorXd& p, RealisationValues& v) const;
    /// so(3) on its three coordinates (x3, p3: their values; the blocks 3 x 3, column-major): eval_lanes' alpha,
    /// delta and their derivatives, check_lanes' values and delta_lanes' delta there (poisson/realisation_lanes.ipp).
    template <class T>
    void rotation_eval(const T* x3, const T* p3, T* alpha, T* delta, T* alpha_x, T* alpha_p, T* delta_x,
                       T* delta_p) const;
    template <class T>
    void rotation_check(const T* x3, const T* p3, T* alpha, T* delta, T* size, T* shift) const;
    template <class T>
    void rotation_delta(const T* x3, const T* p3, T* delta) const;
    /// The compiled polynomial form at (x, p): alpha and delta written, the derivatives' values returned
    /// (alpha_x, delta_x on pattern_x_, then alpha_p, delta_p on pattern_p_, in pattern order).
    const double* eval_polynomial(const Eigen::VectorXd& x, const Eigen::VectorXd& p, Eigen::VectorXd& alpha,
                                  Eigen::VectorXd& delta) const;
    void form_L(const Eigen::VectorXd& p) const;
    void coth_form(bool derivatives) const;
    void alpha_sizes(const Eigen::VectorXd& x, const Eigen::MatrixXd& ax, RealisationCheck& c) const;

    std::size_t n_ = 0;
    Form form_ = Form::polynomial;
    SparsePattern a_pattern_;           // log-canonical: column j holds the l with a_lj != 0 ...
    std::vector<double> a_values_;      // ... and a_lj, in pattern order
    std::vector<int> a_to_x_, a_to_p_;  // ... and where entry (j, l) of the derivatives sits in pattern_x_, pattern_p_
    std::vector<int> diagonal_x_;       // log-canonical: where (j, j) sits in pattern_x_
    SparsePattern pattern_x_, pattern_p_;
    mutable RealisationValues dense_;  // Lie-Poisson forms: evaluated dense, then gathered on the (full) patterns
    std::vector<Eigen::MatrixXd> C_;   // Lie-Poisson: C_[j](i, k) = c_ij^k = dL(p)/dp_j
    // Lie-Poisson: B_m / m!, m = 0..D; rotation: b_2j = B_2j / (2j)!, j = 1..20, then -j b_2(j+1), j = 1..19 (the
    // derivative's coefficients of h(s) = sum_j b_2j (-s)^(j-1))
    std::vector<double> b_;
    std::vector<double> b_low_;  // Lie-Poisson: B_m / m! - b_m, each rounded (the acceptance test's series)
    double axial_[3][3] = {};    // rotation: the axial vector c_j of each C_j (C_j v = c_j x v), read at every step
    double axial_sign_ = 0;      // rotation: s where every c_j = s e_j (s = +-1: so(3) itself), else 0
    int block_[3] = {0, 1, 2};   // rotation: the coordinates of its three non-zero rows, in order
    std::vector<double> q_;      // Lie-Poisson: B_2j / (2j)!, j = 0..J, Q's series at |Z| <= 1
    double radius_ = 0;          // Lie-Poisson: |L|_inf up to which the series b_ is exact to round-off
    CompiledMap map_;         // polynomial: alpha, delta, alpha_x, delta_x (pattern_x_), alpha_p, delta_p (pattern_p_)
    CompiledMap values_map_;  // polynomial: alpha - x, then the neglected parts
    CompiledMap size_map_;    // polynomial: alpha with every coefficient replaced by its absolute value
    CompiledMap delta_map_;   // polynomial: delta alone
    // log-canonical and polynomial: the leading coordinates the lane forms act on (leading_dimension), and when they
    // are fewer than n_, the polynomial form's patterns and maps on them alone
    std::size_t lead_ = 0;
    // Lie-Poisson: the coordinates before those with no bracket (PoissonStructure::moving_dimension), which L(p)'s
    // columns read: |L^m x| <= |L|^m |x| over them
    std::size_t moving_ = 0;
    struct LeadMaps {
        SparsePattern pattern_x, pattern_p;
        CompiledMap map, values, size, delta;
    };
    LeadMaps leading_;
    mutable Eigen::VectorXd in_, out_, u_, v_prev_, v_next_;
    mutable Eigen::MatrixXd L_, W_prev_, W_next_, power_, tmp_;
    // Lie-Poisson, scaling and squaring: Z, its square, Q and its next, a^2, and dQ/dp_j for each j
    mutable Eigen::MatrixXd Z_, Y_, Q_, Qn_, A2_, M_, G_;
    mutable std::vector<Eigen::MatrixXd> dQ_;
    mutable Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace pgi
