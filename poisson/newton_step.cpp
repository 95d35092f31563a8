#include "poisson/newton_step.hpp"

#include "poisson/bisection.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace pgi {

std::string to_string(StepStatus s) {
    switch (s) {
        case StepStatus::ok: return "ok";
        case StepStatus::newton_not_converged: return "Newton did not converge";
        case StepStatus::non_finite: return "non-finite state";
        case StepStatus::truncation_above_bound: return "realisation truncated above its bound";
        case StepStatus::ill_conditioned: return "ill-conditioned step (terms far larger than the state)";
    }
    return "?";
}

namespace {

constexpr double unit_roundoff = std::numeric_limits<double>::epsilon() / 2;

std::vector<double> phase_point(const Eigen::VectorXd& x, const Eigen::VectorXd& p) {
    std::vector<double> point(x.data(), x.data() + x.size());
    point.insert(point.end(), p.data(), p.data() + p.size());
    return point;
}

// |A_m(x, p)|_inf / |x|_inf for m = 0..D (slow, exact-coefficient evaluation: build time only).
std::vector<double> component_sizes(const Realisation& r, const std::vector<double>& point, double scale) {
    std::vector<double> a(r.degree + 1, 0.0);
    for (std::size_t m = 0; m <= r.degree; ++m)
        for (const auto& s : r.alpha) a[m] = std::max(a[m], std::abs(evaluate(s[m], point)) / scale);
    return a;
}

// The geometric decay of the sizes a[m] = |A_m|/|x| measured through the probe's degree, fitted on the last
// four non-zero ones, extrapolated past it: a[last] rho^(m - last); infinite while no decay is seen, zero
// once the series has ended (two measured degrees past the last non-zero one).
class Decay {
public:
    explicit Decay(const std::vector<double>& a) {
        std::vector<std::size_t> nz;
        for (std::size_t m = 1; m < a.size(); ++m)
            if (a[m] > 0) nz.push_back(m);
        if (nz.empty() || a.size() - 1 >= nz.back() + 2) return;  // ended
        last_ = nz.back(), size_ = a[last_];
        const std::size_t lo = nz[nz.size() >= 4 ? nz.size() - 4 : 0];
        rho_ = lo < last_ ? std::pow(size_ / a[lo], 1.0 / double(last_ - lo)) : 1.0;
    }
    double at(std::size_t m) const {
        if (size_ == 0) return 0;
        return rho_ >= 1 ? std::numeric_limits<double>::infinity() : size_ * std::pow(rho_, double(m - last_));
    }
    // the first degree past `from` whose extrapolated size is at most target (from + 1 if none is known)
    std::size_t reaching(double target, std::size_t from) const {
        if (size_ == 0 || rho_ >= 1) return from + 1;
        const double steps = std::ceil(std::log(target / size_) / std::log(rho_));
        return std::max(from + 1, last_ + static_cast<std::size_t>(std::max(0.0, steps)));
    }

private:
    std::size_t last_ = 0;
    double size_ = 0, rho_ = 0;
};

// Symmetric realisations of some structures (constant, linear) have vanishing odd parts: then one measured
// neglected degree can be an identically zero one, and two are needed.
bool has_parity_gaps(const std::vector<double>& a) {
    for (std::size_t m = 1; m + 1 < a.size(); ++m)
        if (a[m] == 0 && *std::max_element(a.begin() + std::ptrdiff_t(m) + 1, a.end()) > 0) return true;
    return false;
}

// The smallest D >= D_min whose neglected terms are below round-off at the typical state: the measured ones
// (one degree at least past D, two where parity gaps appear) and the fitted decay's next two beyond the probe.
// Deepens the probe to where the fitted decay says D lies, one degree past it, until found or the cap.
// Sets truncation to the largest neglected size (measured or extrapolated): at the cap it may be large.
std::size_t choose_degree(const PoissonStructure& pi, const StepOptions& opt, std::size_t D_min, Realisation& probe,
                          const std::vector<double>& point, double scale, double& truncation) {
    const double target = unit_roundoff / 4;
    for (;;) {
        const auto a = component_sizes(probe, point, scale);
        const Decay decay(a);
        const std::size_t top = probe.degree, need = has_parity_gaps(a) ? 2 : 1;
        const auto tail = [&](std::size_t d) {
            return std::max({*std::max_element(a.begin() + std::ptrdiff_t(d) + 1, a.end()), decay.at(top + 1), decay.at(top + 2)});
        };
        for (std::size_t d = D_min; d + need <= top; ++d)
            if (tail(d) <= target || d == opt.max_degree) {
                truncation = tail(d);
                return d;
            }
        const std::size_t next = std::min(decay.reaching(target, top) - 1 + need, opt.max_degree + need);
        probe = build_realisation(pi, opt.realisation, std::max(next, top + 1));
    }
}

// One Newton iteration's cost in multiply-adds, roughly: grad and Hess of S_dt, the realisation with its
// derivatives, the LU solve, and a fixed 150 for what is not arithmetic (calls, pivoting, the update),
// which measured F+J times on the bundled scenes put at 100-200 predictor terms' worth.
double iteration_cost(const CompiledMap& gradient, const RealisationEvaluator& r, const NewtonMatrix& J) {
    return static_cast<double>(gradient.num_terms() + gradient.num_monomials() + r.cost(J.solver() == NewtonSolver::sparse)) + J.cost() + 150;
}

// Newton iterations from a start of relative error e: each squares the error, and the step stops after
// the first correction below tol (the next would be ~tol^2).
int expected_iterations(double e, double tol) {
    int it = 1;
    for (; e > tol && it < 8; ++it) e *= e;
    return it;
}

// The predictor order P minimising (terms of the predictor) + (expected iterations) x (one iteration's
// cost), the iterations expected from the first neglected term dt^(P+1) u_(P+1) at the typical state.
// Fed the base point's series order by order (base_point_series' `enough`); stops at the first order
// expecting one iteration, or once the next orders cannot win or cost more exact work than they save.
// Deterministic: the choice depends on the scene only.
class PredictorChoice {
public:
    static constexpr double cheap_order_terms = 500;
    /// cap_stops: whether an order above cheap_order_terms stops the choice (not while scoring the orders
    /// computed anyway, through the first pass's limit).
    PredictorChoice(const StepOptions& opt, double iteration_cost, std::vector<double> point, double scale, std::size_t limit,
                    bool cap_stops = true)
        : opt_(opt), iteration_cost_(iteration_cost), point_(std::move(point)), scale_(scale), limit_(limit), cap_stops_(cap_stops) {}
    bool operator()(const std::vector<Series>& v) {
        const std::size_t s = v.front().order() - 1;  // exact through dt^s: scores the order P = s - 1
        double e = 0, terms = 0, top = 0;
        for (const auto& vl : v) {
            e = std::max(e, std::abs(std::pow(opt_.dt, double(s)) * evaluate(vl[s], point_)) / scale_);
            for (std::size_t m = 1; m < s; ++m) terms += static_cast<double>(vl[m].length());
            top += static_cast<double>(vl[s].length());
        }
        const int iterations = expected_iterations(e, opt_.newton_tol);
        const double cost = terms + iterations * iteration_cost_;
        if (!best_ || cost < best_cost_) best_ = s - 1, best_cost_ = cost;
        // Every order costs at least one iteration: the next (terms + top) wins only below best - one
        // iteration. An order computed from more than cheap_order_terms new terms costs several times the
        // last in exact work (seconds from ~2000 terms in 6 variables: e(3)* k = 4 spent 26 s on orders 6-7
        // to save one iteration in two), more than a run saves: the choice stays among the cheap orders.
        // A first neglected term that does not shrink means the series diverges at this dt.
        const bool hopeless = terms + top >= best_cost_ - iteration_cost_;
        const bool diverging = e_ > 0 && e >= e_;
        const bool capped = top > cheap_order_terms;
        capped_ = capped_ || capped;
        const bool decided = iterations == 1 || hopeless || (capped && cap_stops_) || diverging;
        at_limit_ = !decided && s >= limit_ + 1;
        e_ = e;
        return decided || s >= limit_ + 1;
    }
    std::size_t order() const { return best_.value_or(0); }
    /// Whether the choice stopped only because its limit was reached (a higher limit could choose otherwise)
    /// with every order seen within the cap.
    bool at_limit() const { return at_limit_ && !capped_; }

private:
    const StepOptions& opt_;
    double iteration_cost_;
    std::vector<double> point_;
    double scale_;
    std::size_t limit_;
    std::optional<std::size_t> best_;
    double best_cost_ = 0;
    double e_ = 0;  // of the order before
    bool cap_stops_;
    bool at_limit_ = false, capped_ = false;
};

// dx = J^{-1} r by Eigen's partial-pivoting LU; at the common small sizes on fixed-size matrices,
// which live on the stack and unroll, otherwise by the stepper's preallocated dynamic LU.
template <int N>
void solve_fixed(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, Eigen::VectorXd& dx) {
    const Eigen::PartialPivLU<Eigen::Matrix<double, N, N>> lu{Eigen::Matrix<double, N, N>(J)};
    dx = lu.solve(Eigen::Matrix<double, N, 1>(r));
}

void solve(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, Eigen::VectorXd& dx, Eigen::PartialPivLU<Eigen::MatrixXd>& lu) {
    switch (J.rows()) {
        case 2: return solve_fixed<2>(J, r, dx);
        case 3: return solve_fixed<3>(J, r, dx);
        case 4: return solve_fixed<4>(J, r, dx);
        case 6: return solve_fixed<6>(J, r, dx);
        default: lu.compute(J); dx.noalias() = lu.solve(r);
    }
}

}  // namespace

namespace {

// The realisation's parts of degrees D + 1 and D + 2 (what exists of them in the probe), for the step's
// truncation check at the solution.
std::vector<Poly> neglected_parts(const Realisation& probe, std::size_t D) {
    std::vector<Poly> parts;
    for (std::size_t m = D + 1; m <= std::min(D + 2, probe.degree); ++m)
        for (const auto& a : probe.alpha) parts.push_back(a[m]);
    return parts;
}

// How alpha is evaluated: a closed form where there is one (log-canonical; so(3)*-type; any other Lie-Poisson
// structure by its series to the degree whose tail is below round-off at the typical state, by scaling and
// squaring beyond), otherwise the compiled series truncated at the degree choose_degree finds.
RealisationEvaluator make_evaluator(const PoissonStructure& pi, const StepOptions& opt, std::size_t D_min, Realisation& probe,
                                    const std::vector<double>& point, const Eigen::VectorXd& p0, double scale, StepInfo& info) {
    const StructureClass cls = pi.structure_class();
    const RealisationForm form = realisation_form(cls, opt.realisation);
    if (form == RealisationForm::log_canonical) {
        info = {probe.method + " (closed form)", 0, true, 0.0, 0};
        return RealisationEvaluator::log_canonical(pi);
    }
    if (form == RealisationForm::lie_poisson && RealisationEvaluator::has_rotation_form(pi)) {
        info = {probe.method + " (closed form, so(3))", 0, true, 0.0, 0};
        return RealisationEvaluator::rotation(pi);
    }
    if (form == RealisationForm::lie_poisson) {
        // |L| may grow along the orbit and during Newton: a margin of 1.5 before scaling and squaring takes over
        const double norm = RealisationEvaluator::lie_poisson(pi, 0).operator_norm_at(p0);
        const std::size_t D = RealisationEvaluator::series_degree_for(1.5 * norm, std::max<std::size_t>(D_min, 2), opt.max_degree);
        info = {probe.method + " (series, scaling and squaring beyond)", D, true, 0.0, 0};
        return RealisationEvaluator::lie_poisson(pi, D);
    }
    info.degree = choose_degree(pi, opt, D_min, probe, point, scale, info.truncation_estimate);
    info.method = probe.method;
    info.exact_realisation = form == RealisationForm::constant;
    return RealisationEvaluator::polynomial(pi, truncated(probe, info.degree), neglected_parts(probe, info.degree));
}

}  // namespace

NewtonStepper NewtonStepper::build(const PoissonStructure& pi, const Poly& H, const StepOptions& opt,
                                   const Eigen::VectorXd& x_typical) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim();
    if (opt.k < 1) throw std::invalid_argument("NewtonStepper: the order k must be at least 1");
    if (!(opt.dt > 0) || !std::isfinite(opt.dt)) throw std::invalid_argument("NewtonStepper: dt must be positive and finite");
    if (static_cast<std::size_t>(x_typical.size()) != n || !x_typical.allFinite())
        throw std::invalid_argument("NewtonStepper: the typical state must have " + std::to_string(n) + " finite values");

    NewtonStepper s;
    s.k_ = opt.k;
    s.dt_ = opt.dt;
    s.opt_ = opt;
    const Rational dt = Rational::from_double(opt.dt);
    const StructureClass cls = pi.structure_class();
    const bool radial = realisation_form(cls, opt.realisation) == RealisationForm::radial;
    // the predictor's order: as asked, or chosen below among 0..max(k + 1, 8) (which needs one order more);
    // a radial realisation is probed from the degree S_k needs and deepened only as far as the step's own
    // degree D needs (its exact recursion is the costly part): the predictor then reads at most that degree
    const std::size_t D_min = std::max<std::size_t>(realisation_degree_for_order(opt.k), 1);
    const std::size_t P_wanted = opt.predictor_order ? opt.predictor_order : std::max<std::size_t>(opt.k + 1, 8) + 1;
    const std::size_t radial_start = std::max(D_min + 2, opt.predictor_order);  // two measured degrees to fit
    // a closed form is built through the degree the predictor's first pass reads (below), deeper only if it goes on:
    // at large n every degree holds O(n) terms
    const auto closed_degree = [&](std::size_t P) { return std::max(D_min, P) + 2; };
    const std::size_t P_first_wanted = opt.predictor_order ? P_wanted : std::min<std::size_t>(P_wanted, 3);
    Realisation probe = build_realisation(pi, opt.realisation, radial ? radial_start : closed_degree(P_first_wanted));
    auto S = hamilton_jacobi_terms(M, probe, H, opt.k);
    Poly S_dt = sum_powers(S, dt, 1);  // S_dt = sum_j dt^j S_j, exactly in the double dt

    // p at the typical state, to size the realisation's terms there.
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    Eigen::VectorXd p0(static_cast<Eigen::Index>(n));
    for (std::size_t l = 0; l < n; ++l)
        p0[static_cast<Eigen::Index>(l)] = evaluate(derivative(S_dt, M.x(l)), phase_point(x_typical, zero));
    const double scale = std::max(x_typical.lpNorm<Eigen::Infinity>(), std::numeric_limits<double>::min());
    s.realisation_ = make_evaluator(pi, opt, D_min, probe, phase_point(x_typical, p0), p0, scale, s.info_);
    s.gradient_ = compile_gradient(M, S_dt);
    s.matrix_ = NewtonMatrix(s.realisation_.pattern_x(), s.realisation_.pattern_p(), s.gradient_.hessian, opt.solver);
    s.sparse_ = s.matrix_.solver() == NewtonSolver::sparse;
    s.info_.solver = s.matrix_.solver();

    // xb = x + sum_m dt^m u_m, from the exact series of the base point, to the order chosen.
    const std::size_t P = radial ? std::min(P_wanted, probe.degree) : P_wanted;
    const double cost = iteration_cost(s.gradient_.with_hessian, s.realisation_, s.matrix_);
    // The displacement's exact series is computed to the limit's order before the choice sees it, and at large n
    // (the lattices) each order holds O(n) terms: the choice first scores P = 0..2 (all of them: they are computed
    // anyway) and goes on to P only when the limit alone stopped it and no order passed the cap.
    const std::size_t P_first = std::min<std::size_t>(P, 3);
    std::optional<PredictorChoice> choice;
    choice.emplace(opt, cost, phase_point(x_typical, zero), scale, P_first - 1, false);
    auto u = opt.predictor_order ? base_point_series(M, probe, S, P) : base_point_series(M, probe, S, P_first, std::ref(*choice));
    if (!opt.predictor_order && choice->at_limit() && P_first < P) {
        if (probe.degree < P) probe = build_realisation(pi, opt.realisation, closed_degree(P));
        choice.emplace(opt, cost, phase_point(x_typical, zero), scale, P - 1);
        u = base_point_series(M, probe, S, P, std::ref(*choice));
    }
    s.info_.predictor_order = opt.predictor_order ? P : choice->order();
    std::vector<Poly> xb;
    for (std::size_t l = 0; l < n; ++l) {
        std::vector<Poly> c;
        for (std::size_t m = 0; m < s.info_.predictor_order; ++m) c.push_back(u[m][l]);
        xb.push_back(c.empty() ? M.x_gen(l) : M.x_gen(l) + sum_powers(c, dt, 1));
    }
    s.predictor_ = CompiledMap::build(xb, M.coordinate_vars());
    s.size_scratch(n);
    return s;
}

void NewtonStepper::size_scratch(std::size_t n) {
    const auto N = static_cast<Eigen::Index>(n);
    check_ = RealisationCheck(n);
    for (auto* v : {&xb_, &xb_good_, &p_, &r_, &dx_, &gsize_, &tol_}) v->setZero(N);
    gh_.setZero(N + static_cast<Eigen::Index>(gradient_.hessian.nonzeros()));
    if (sparse_) {  // nothing n x n: the values live on the patterns
        sparse_values_ = realisation_.sparse_values();
        return;
    }
    v_ = RealisationValues(n);
    hess_.setZero(N, N);
    J_.setZero(N, N);
    D_.setZero(N, N);
    lu_ = Eigen::PartialPivLU<Eigen::MatrixXd>(N);
}

void NewtonStepper::evaluate_at(const Eigen::VectorXd& xb) {
    const auto n = xb.size();
    gradient_.with_hessian.eval(xb.data(), gh_.data());
    p_ = gh_.head(n);
    if (sparse_) {
        realisation_.eval(xb, p_, sparse_values_);
        return;
    }
    gradient_.hessian.scatter(gh_.data() + n, hess_);
    realisation_.eval(xb, p_, v_);
}

// J = alpha_x + alpha_p Hess S_dt at the point evaluate_at saw.
void NewtonStepper::assemble() {
    if (sparse_) {
        matrix_.assemble(sparse_values_.alpha_x.data(), sparse_values_.alpha_p.data(), gh_.data() + p_.size());
        return;
    }
    J_ = v_.alpha_x;
    J_.noalias() += v_.alpha_p * hess_;
}

const Eigen::MatrixXd& NewtonStepper::newton_system(const Eigen::VectorXd& xb) {
    evaluate_at(xb);
    assemble();
    if (sparse_) J_ = matrix_.dense();
    return J_;
}

// kappa of the residual's tolerance kappa u (|x| + sizes of the terms summed): evaluating a sum of terms
// of total size T costs a few roundings of T per level of the evaluation (monomials of degree d carry
// ~d u each, Horner and matrix products ~n u), and r = alpha - x one more: 64 covers degrees and
// dimensions to ~30 with room; a state off by more is not a solution of the step's equation.
constexpr double residual_kappa = 64;

// The acceptance test at the current base point: p = grad S_dt(xb), alpha, delta and the term sizes there,
// r = alpha - x against its componentwise tolerance, and the realisation's neglected terms. After a small
// correction p is updated by the Hessian (exact to O(|dx|^2), below round-off once |dx| <= 1e-9 |x|) instead of
// evaluated anew; the round-off of grad S_dt's terms, carried into alpha by alpha_p (from the last Newton
// system), is added to the tolerance only if the test fails without it (the stricter test passing suffices).
bool NewtonStepper::accept_check(const Eigen::VectorXd& x, bool small_correction) {
    if (small_correction) {
        if (sparse_)
            gradient_.hessian.multiply(gh_.data() + p_.size(), dx_, r_);
        else
            r_.noalias() = hess_ * dx_;
        p_ -= r_;
    } else {
        gradient_.gradient.eval(xb_.data(), p_.data());
    }
    realisation_.check(xb_, p_, check_);
    r_ = check_.alpha - x;
    residual_ = r_.lpNorm<Eigen::Infinity>();
    tol_ = residual_kappa * unit_roundoff * (x.cwiseAbs() + check_.size);
    if (!within_tolerance()) {
        r_ = xb_.cwiseAbs();
        gradient_.gradient_size.eval(r_.data(), gsize_.data());
        add_propagated_sizes();
        r_ = check_.alpha - x;
        within_tolerance();
    }
    tolerance_ = tol_.lpNorm<Eigen::Infinity>();
    const double size = std::max({x.lpNorm<Eigen::Infinity>(), xb_.lpNorm<Eigen::Infinity>(), std::numeric_limits<double>::min()});
    truncation_ = check_.neglected / size;
    return ratio_ <= 1;
}

// tol_i += kappa u sum_l |alpha_p(i, l)| gsize_l: the round-off of grad S_dt's terms carried into alpha_i, over
// alpha_p's pattern on the sparse path.
void NewtonStepper::add_propagated_sizes() {
    const double c = residual_kappa * unit_roundoff;
    if (sparse_) {
        const SparsePattern& P = realisation_.pattern_p();
        for (std::size_t l = 0; l < P.cols; ++l)
            for (int k = P.outer[l]; k < P.outer[l + 1]; ++k)
                tol_[P.inner[std::size_t(k)]] += c * std::abs(sparse_values_.alpha_p[std::size_t(k)]) * gsize_[Eigen::Index(l)];
        return;
    }
    const auto n = tol_.size();
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index l = 0; l < n; ++l) tol_[i] += c * std::abs(v_.alpha_p(i, l)) * gsize_[l];
}

// ratio_ = max_i |r_i| / tol_i; whether it is at most 1.
bool NewtonStepper::within_tolerance() {
    ratio_ = 0;
    for (Eigen::Index i = 0; i < r_.size(); ++i) ratio_ = std::max(ratio_, std::abs(r_[i]) / std::max(tol_[i], std::numeric_limits<double>::min()));
    return ratio_ <= 1;
}

// Newton from the predicted xb_: corrections until one is small (or stalls at round-off), then the
// acceptance test; a failed test goes on iterating. The increment is delta at the accepted base point.
StepStatus NewtonStepper::newton(const Eigen::VectorXd& x, Eigen::VectorXd& increment) {
    double previous = std::numeric_limits<double>::infinity(), previous_residual = previous, good_residual = previous, lambda = 1;
    for (int it = 1; it <= opt_.newton_max_iter; ++it) {
        // r = alpha(xb, grad S_dt(xb)) - x;  J = alpha_x + alpha_p Hess S_dt
        evaluate_at(xb_);
        assemble();
        r_ = evaluated_alpha() - x;
        residual_ = r_.lpNorm<Eigen::Infinity>();
        // Far from the solution (large steps) a full correction may overshoot: back along it, halving,
        // while the residual grows above sqrt(u) |x| (below, growth is round-off noise).
        const double noise = std::sqrt(unit_roundoff) * std::max(x.lpNorm<Eigen::Infinity>(), xb_.lpNorm<Eigen::Infinity>());
        if (!(residual_ <= good_residual) && !(residual_ <= noise) && lambda > 1.0 / 64) {
            lambda /= 2;
            xb_ = xb_good_ - lambda * dx_;
            continue;
        }
        if (!std::isfinite(residual_) || !evaluated_delta().allFinite()) return StepStatus::non_finite;
        good_residual = residual_, lambda = 1;
        xb_good_ = xb_;
        if (sparse_) {
            if (!matrix_.solve(r_, dx_)) return StepStatus::non_finite;  // J singular
        } else {
            solve(J_, r_, dx_, lu_);
        }
        xb_ -= dx_;
        iterations_ = it;
        correction_ = dx_.lpNorm<Eigen::Infinity>();
        if (!std::isfinite(correction_)) return StepStatus::non_finite;
        const double scale = std::max(x.lpNorm<Eigen::Infinity>(), xb_.lpNorm<Eigen::Infinity>());
        // small, or neither it nor the residual halving any more: Newton has reached its evaluation's round-off
        const bool small = correction_ <= opt_.newton_tol * scale;
        const bool settled = small || (correction_ > previous / 2 && residual_ > previous_residual / 2);
        previous = correction_, previous_residual = residual_;
        if (!settled || !accept_check(x, small)) continue;
        if (!(tolerance_ <= std::sqrt(unit_roundoff) * std::max(x.lpNorm<Eigen::Infinity>(), xb_.lpNorm<Eigen::Infinity>())))
            return StepStatus::ill_conditioned;
        increment = check_.delta;
        if (!increment.allFinite()) return StepStatus::non_finite;
        return truncation_ > opt_.truncation_bound ? StepStatus::truncation_above_bound : StepStatus::ok;
    }
    return StepStatus::newton_not_converged;
}

StepStatus NewtonStepper::step(const Eigen::VectorXd& x, Eigen::VectorXd& increment) {
    iterations_ = 0;
    residual_ = tolerance_ = ratio_ = truncation_ = 0;
    if (!x.allFinite()) return StepStatus::non_finite;
    predictor_.eval(x.data(), xb_.data());
    const StepStatus first = newton(x, increment);
    if (first == StepStatus::ok || first == StepStatus::truncation_above_bound || info_.predictor_order == 0) return first;
    // NOTE: far outside the predictor's range (stiff steps), Newton may still converge from xb = x.
    const int spent = iterations_;
    xb_ = x;
    const StepStatus second = newton(x, increment);
    iterations_ += spent;
    return second;
}

double NewtonStepper::residual_at_solution(const Eigen::VectorXd& x) {
    evaluate_at(xb_);
    return (evaluated_alpha() - x).lpNorm<Eigen::Infinity>();
}

Eigen::MatrixXd NewtonStepper::tangent_map(const Eigen::VectorXd& x) {
    Eigen::VectorXd inc(x.size());
    if (step(x, inc) != StepStatus::ok) throw std::runtime_error("NewtonStepper::tangent_map: the step failed");
    newton_system(xb_);
    if (sparse_) {  // the dense blocks from the patterns: a tangent map is dense anyway
        v_ = RealisationValues(dim());
        realisation_.eval(xb_, p_, v_);
        gradient_.hessian.scatter(gh_.data() + p_.size(), hess_);
    }
    D_ = v_.delta_x;
    D_.noalias() += v_.delta_p * hess_;
    // x = alpha(xb(x)) gives dxb/dx = J^{-1}; x_new = beta(xb) = alpha + delta, so Dphi = (J + D) J^{-1}
    return Eigen::MatrixXd::Identity(x.size(), x.size()) + D_ * J_.inverse();
}

}  // namespace pgi
