#include "poisson/newton_step.hpp"
#include "series/machine_code.hpp"

#include "poisson/detail/newton_internals.hpp"
#include "poisson/detail/truncation_degree.hpp"
#include "series/native_tier.hpp"

#include "poisson/lane_step.hpp"
#include "poisson/detail/newton_rules.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace pgi {

// Here, where LaneSteps and Internals are defined (series/value_ptr.hpp); a stepper always holds its Internals (a
// moved-from one excepted, which may only be assigned to or destroyed).
NewtonStepper::NewtonStepper() {
    in_.emplace();
}
NewtonStepper::NewtonStepper(const NewtonStepper&) = default;
NewtonStepper::NewtonStepper(NewtonStepper&&) noexcept = default;
NewtonStepper& NewtonStepper::operator=(const NewtonStepper&) = default;
NewtonStepper& NewtonStepper::operator=(NewtonStepper&&) noexcept = default;
NewtonStepper::~NewtonStepper() = default;

const Predictor& NewtonStepper::predictor() const {
    return in_->predictor_;
}

const DtSeriesMap& NewtonStepper::with_hessian() const {
    return in_->gradient_.with_hessian;
}

const Eigen::VectorXd& NewtonStepper::evaluated_alpha() const {
    return sparse_ ? in_->sparse_values_.alpha : in_->v_.alpha;
}

const Eigen::VectorXd& NewtonStepper::evaluated_delta() const {
    return sparse_ ? in_->sparse_values_.delta : in_->v_.delta;
}

std::size_t NewtonStepper::lane_dimension() const {
    if (!lane_) return 0;
    return std::visit([](const auto& lane) { return std::size_t(std::decay_t<decltype(lane)>::dimension); },
                      lane_->step);
}

std::string to_string(StepStatus s) {
    switch (s) {
        case StepStatus::ok:
            return "ok";
        case StepStatus::newton_not_converged:
            return "Newton did not converge";
        case StepStatus::non_finite:
            return "non-finite state";
        case StepStatus::truncation_above_bound:
            return "realisation truncated above its bound";
        case StepStatus::ill_conditioned:
            return "ill-conditioned step (terms far larger than the state)";
    }
    return "?";
}

namespace {

void check_build_arguments(const PhaseSpace& M, const std::vector<Poly>* S, const StepOptions& opt,
                           const Eigen::VectorXd& x_typical) {
    const std::size_t n = M.dim();
    if (opt.k < 1) throw std::invalid_argument("NewtonStepper: the order k must be at least 1");
    if (S && S->size() != opt.k)
        throw std::invalid_argument("NewtonStepper: " + std::to_string(opt.k) + " Hamilton-Jacobi terms expected, " +
                                    std::to_string(S->size()) + " given");
    if (!(opt.dt > 0) || !std::isfinite(opt.dt))
        throw std::invalid_argument("NewtonStepper: dt must be positive and finite");
    if (static_cast<std::size_t>(x_typical.size()) != n || !x_typical.allFinite())
        throw std::invalid_argument("NewtonStepper: the typical state must have " + std::to_string(n) +
                                    " finite values");
}

// What the Newton matrix's Hessian may neglect (compile_gradient): J moved by at most u / newton_tol at x_typical,
// alpha_p's size there estimated by |pi(x_typical)|_inf (alpha = x + pi(x) p / 2 + O(p^2): a factor 2 for the O(p)).
// Only small dense problems truncate: pi is not evaluated on the others.
HessianTruncation newton_matrix_truncation(const PoissonStructure& pi, const StepOptions& opt,
                                           const Eigen::VectorXd& x_typical) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim();
    if (n > hessian_truncation_dim || !(opt.newton_tol > 0)) return HessianTruncation{};
    HessianTruncation t{std::span<const double>(x_typical.data(), n), 0, unit_roundoff / opt.newton_tol};
    const std::vector<double> point = M.point(t.x_typical);
    for (std::size_t i = 0; i < n; ++i) {
        double row = 0;
        for (std::size_t j = 0; j < n; ++j) row += std::abs(evaluate(pi(i, j), point));
        t.alpha_p_size = std::max(t.alpha_p_size, row);
    }
    return t;
}

// The coordinates whose rows of pi are zero (compile_gradient's passive ones: a scheme's parameters, say).
std::vector<bool> zero_rows(const PoissonStructure& pi) {
    std::vector<bool> zero(pi.dim());
    for (std::size_t i = 0; i < pi.dim(); ++i) zero[i] = pi.row_support(i).empty();
    return zero;
}

}  // namespace

NewtonStepper NewtonStepper::build(const PoissonStructure& pi, const std::vector<Poly>& S,
                                   const RealisationSource& realisation, const StepOptions& opt,
                                   const Eigen::VectorXd& x_typical) {
    const PhaseSpace& M = pi.phase_space();
    const std::size_t n = M.dim();
    check_build_arguments(M, &S, opt, x_typical);
    NewtonStepper s;
    s.k_ = opt.k;
    s.dt_ = s.step_dt_ = opt.dt;
    s.opt_ = opt;
    s.moving_ = pi.moving_dimension();
    // the typical state's size, as the steps measure sizes: the predictor's error and the truncation are relative to it
    const double scale = std::max(s.state_norm(x_typical), std::numeric_limits<double>::min());
    s.in_->gradient_ = compile_gradient(M, S, opt.dt, newton_matrix_truncation(pi, opt, x_typical), zero_rows(pi));

    // the truncation degree (and evaluator), sized by its terms at x_typical's magnitudes: docs/math.md 4 and 6
    Eigen::VectorXd p0(static_cast<Eigen::Index>(n));
    s.in_->gradient_.gradient.eval(x_typical.data(), opt.dt, p0.data());
    SizePoint sizes{x_typical.cwiseAbs(), Eigen::VectorXd(static_cast<Eigen::Index>(n))};
    s.in_->gradient_.gradient_size.eval(sizes.x.data(), opt.dt, sizes.p.data());
    RealisationPtr probe = realisation(probe_degree(realisation_form(pi.structure_class(), opt.realisation), opt, n));
    StepRealisation r = step_realisation(pi, opt, probe, realisation, scale, p0, sizes);
    s.in_->realisation_ = std::move(r.evaluator);
    s.in_->simplified_newton_ = r.simplified_newton;
    s.info_ = {std::move(r.method), r.degree, r.exact, r.truncation_estimate, 0};
    // J = alpha_x + alpha_p Hess S_dt on its pattern: dense or sparse (NewtonMatrix::choose)
    s.in_->matrix_ = NewtonMatrix(s.in_->realisation_.pattern_x(), s.in_->realisation_.pattern_p(),
                                  s.in_->gradient_.hessian, opt.solver);
    s.sparse_ = s.in_->matrix_.solver() == NewtonSolver::sparse;
    s.info_.solver = s.in_->matrix_.solver();

    // the predictor, xb = x + sum_m dt^m u_m, its order chosen by cost at opt.dt
    // (the acceptance test's evaluation of alpha costs about a third of eval's, which adds the derivatives)
    const NewtonCost cost =
        newton_cost(s.in_->gradient_.with_hessian.planned_cost() + s.in_->realisation_.cost(s.sparse_),
                    s.in_->gradient_.gradient.planned_cost() + s.in_->realisation_.cost(s.sparse_) / 3,
                    s.in_->matrix_.factor_cost(), s.in_->matrix_.solve_cost(), s.in_->simplified_newton_);
    // a closed form is deepened for the predictor only if its choice goes past the first orders (the radial
    // recursion is not: its cost is the point of its probe)
    const bool closed = realisation_form(pi.structure_class(), opt.realisation) != RealisationForm::radial;
    s.in_->predictor_ =
        Predictor::choose(M, *probe, S, opt, cost, x_typical, scale, closed ? realisation : RealisationSource{});
    s.info_.predictor_order = s.in_->predictor_.order();
    s.info_.hessian_terms = s.in_->gradient_.hessian_terms;
    s.attach_native(opt.native);
    s.size_scratch(n);
    if (!s.sparse_ && s.in_->realisation_.has_lane_form()) {
        // the realisation's leading coordinates (those past them step by zero), or all of them, whichever a LaneStep
        // is compiled for: a log-canonical system of 5 and a parameter keeps LaneStep<6>
        const auto compiled = [](std::size_t N) { return N == 2 || N == 3 || N == 4 || N == 6; };
        const std::size_t leading = s.in_->realisation_.leading_dimension();
        switch (compiled(leading) ? leading : n) {
            case 2:
                s.lane_.emplace(std::in_place_type<LaneStep<2, double>>, s);
                break;
            case 3:
                s.lane_.emplace(std::in_place_type<LaneStep<3, double>>, s);
                break;
            case 4:
                s.lane_.emplace(std::in_place_type<LaneStep<4, double>>, s);
                break;
            case 6:
                s.lane_.emplace(std::in_place_type<LaneStep<6, double>>, s);
                break;
            default:
                break;
        }
    }
    return s;
}

NewtonStepper NewtonStepper::build(const PoissonStructure& pi, const Poly& H, const StepOptions& opt,
                                   const Eigen::VectorXd& x_typical) {
    check_build_arguments(pi.phase_space(), nullptr, opt, x_typical);
    DeepestRealisation realisation(opt.realisation);
    const RealisationSource source = [&](std::size_t D) { return realisation.through(pi, D); };
    const auto S = hamilton_jacobi_terms(
        pi.phase_space(), *source(probe_degree(realisation_form(pi.structure_class(), opt.realisation), opt, pi.dim())),
        H, opt.k);
    return build(pi, S, source, opt, x_typical);
}

// Those a step at the build's dt runs first (the Newton system's, the predictor's, the realisation's), then those of
// other steps and the acceptance test's rarer ones: native code takes them in this order while they fit.
std::vector<CompiledMap*> NewtonStepper::compiled_maps() {
    const std::vector<DtSeriesMap*> series = {&in_->gradient_.with_hessian, &in_->predictor_.series(),
                                              &in_->gradient_.gradient, &in_->gradient_.gradient_size};
    std::vector<CompiledMap*> maps, later;
    for (DtSeriesMap* m : series) {
        const std::vector<CompiledMap*> c = m->compiled_maps();
        if (c.empty()) continue;
        maps.push_back(c.front());
        later.insert(later.end(), c.begin() + 1, c.end());
    }
    for (CompiledMap* c : in_->realisation_.compiled_maps()) maps.push_back(c);
    maps.insert(maps.end(), later.begin(), later.end());
    return maps;
}

void NewtonStepper::size_lane_maps(BatchScratch& scratch) const {
    std::size_t monomials = 0;
    for (const DtSeriesMap* m : {&in_->gradient_.with_hessian, &in_->gradient_.gradient, &in_->predictor_.series()})
        if (const CompiledMap* planned = m->planned()) monomials = std::max(monomials, planned->num_monomials());
    if (scratch.map.size() < monomials * CompiledMap::batch_lanes)
        scratch.map.resize(monomials * CompiledMap::batch_lanes);
}

void NewtonStepper::set_dt(double dt) {
    if (!(dt > 0) || !std::isfinite(dt)) throw std::invalid_argument("NewtonStepper: dt must be positive and finite");
    dt_ = dt;
}

void NewtonStepper::size_scratch(std::size_t n) {
    const auto N = static_cast<Eigen::Index>(n);
    in_->check_ = RealisationCheck(n);
    for (auto* v : {&xb_, &xb_good_, &p_, &r_, &dx_, &gsize_, &tol_, &moved_}) v->setZero(N);
    gh_.setZero(static_cast<Eigen::Index>(in_->gradient_.with_hessian.width()));
    hessian_.setZero(static_cast<Eigen::Index>(in_->gradient_.hessian.nonzeros()));
    if (sparse_) {  // nothing n x n: the values live on the patterns
        in_->sparse_values_ = in_->realisation_.sparse_values();
        return;
    }
    in_->v_ = RealisationValues(n);
    hess_.setZero(N, N);
    J_.setZero(N, N);
    D_.setZero(N, N);
    in_->algebra_ = DenseAlgebra(n);
}

void NewtonStepper::evaluate_at(const Eigen::VectorXd& xb) {
    in_->gradient_.with_hessian.eval(xb.data(), step_dt_, gh_.data());
    take_gradient_at(xb);
}

// The rest of evaluate_at once gh_ holds grad S_dt(xb) and Hess S_dt(xb): p, the Hessian's dense copy, the
// realisation and its derivatives.
void NewtonStepper::take_gradient_at(const Eigen::VectorXd& xb) {
    const auto n = xb.size();
    p_ = gh_.head(n);
    expand_hessian(in_->gradient_, gh_.data() + n, hessian_.data());
    if (sparse_) {
        in_->realisation_.eval(xb, p_, in_->sparse_values_);
        return;
    }
    in_->gradient_.hessian.scatter(hessian_.data(), hess_);
    in_->realisation_.eval(xb, p_, in_->v_);
}

void NewtonStepper::assemble() {
    if (sparse_) {
        in_->matrix_.assemble(in_->sparse_values_.alpha_x.data(), in_->sparse_values_.alpha_p.data(), hessian_.data());
        return;
    }
    in_->algebra_.jacobian(in_->v_.alpha_x, in_->v_.alpha_p, hess_, J_);
}

const Eigen::MatrixXd& NewtonStepper::newton_system(const Eigen::VectorXd& xb) {
    step_dt_ = dt_;
    return jacobian_at(xb);
}

const Eigen::MatrixXd& NewtonStepper::jacobian_at(const Eigen::VectorXd& xb) {
    evaluate_at(xb);
    assemble();
    if (sparse_)
        J_ = in_->matrix_.dense();  // (the benchmarks' and tangent maps' dense view; Newton reads in_->matrix_)
    return J_;
}

// The acceptance test at the current base point: p = grad S_dt(xb), alpha, delta and the term sizes there,
// r = alpha - x against its componentwise tolerance, and the realisation's neglected terms. After a small
// correction p is updated by the Hessian (exact to O(|dx|^2), below round-off once |dx| <= 1e-9 |x|) instead of
// evaluated anew; the round-off of grad S_dt's terms, carried into alpha by alpha_p (from the last Newton
// system), is added to the tolerance only if the test fails without it (the stricter test passing suffices).
bool NewtonStepper::accept_check(const Eigen::VectorXd& x, bool small_correction) {
    if (small_correction) {
        if (sparse_)
            in_->gradient_.hessian.multiply(hessian_.data(), dx_, r_);
        else
            in_->algebra_.product(hess_, dx_, r_);
        p_ -= r_;
    } else {
        in_->gradient_.gradient.eval(xb_.data(), step_dt_, p_.data());
    }
    in_->realisation_.check(xb_, p_, in_->check_, /*with_delta=*/false);  // (delta once, by finish)
    r_ = (xb_ - x) + in_->check_.shift;                                   // alpha - x to below the ulps of x
    residual_ = r_.lpNorm<Eigen::Infinity>();
    tol_ = residual_kappa * unit_roundoff * (x.cwiseAbs() + in_->check_.size);
    if (!within_tolerance()) {
        r_ = xb_.cwiseAbs();
        in_->gradient_.gradient_size.eval(r_.data(), std::abs(step_dt_), gsize_.data());
        add_propagated_sizes();
        r_ = (xb_ - x) + in_->check_.shift;
        within_tolerance();
    }
    tolerance_ = state_norm(tol_);  // (a parameter's residual is 0: alpha leaves it alone)
    const double size = std::max({state_norm(x), state_norm(xb_), std::numeric_limits<double>::min()});
    truncation_ = in_->check_.neglected / size;
    return ratio_ <= 1;
}

// tol_i += kappa u sum_l |alpha_p(i, l)| gsize_l: the round-off of grad S_dt's terms carried into alpha_i, over
// alpha_p's pattern on the sparse path.
void NewtonStepper::add_propagated_sizes() {
    const double c = residual_kappa * unit_roundoff;
    if (sparse_) {
        const SparsePattern& P = in_->realisation_.pattern_p();
        for (std::size_t l = 0; l < P.cols; ++l)
            for (int k = P.outer[l]; k < P.outer[l + 1]; ++k)
                tol_[P.inner[std::size_t(k)]] +=
                    c * std::abs(in_->sparse_values_.alpha_p[std::size_t(k)]) * gsize_[Eigen::Index(l)];
        return;
    }
    const auto n = tol_.size();
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index l = 0; l < n; ++l) tol_[i] += c * std::abs(in_->v_.alpha_p(i, l)) * gsize_[l];
}

// ratio_ = max_i |r_i| / tol_i; whether it is at most 1.
bool NewtonStepper::within_tolerance() {
    ratio_ = 0;
    for (Eigen::Index i = 0; i < r_.size(); ++i)
        ratio_ = std::max(ratio_, std::abs(r_[i]) / std::max(tol_[i], std::numeric_limits<double>::min()));
    return ratio_ <= 1;
}

// The accepted step's status: ill-conditioned when the tolerance itself exceeds sqrt(u) |x|, else the
// increment (delta at the accepted base point, evaluated here, once a step, and polished) and the truncation's verdict.
StepStatus NewtonStepper::finish(double x_norm, Eigen::VectorXd& increment) {
    if (newton_rules::ill_conditioned(tolerance_, newton_rules::noise(x_norm, state_norm(xb_))))
        return StepStatus::ill_conditioned;
    in_->realisation_.delta(xb_, p_, in_->check_.delta);
    increment = in_->check_.delta;
    polish(increment);
    if (!increment.allFinite()) return StepStatus::non_finite;
    return truncation_ > opt_.truncation_bound ? StepStatus::truncation_above_bound : StepStatus::ok;
}

// After the acceptance test, always: the increment moved to first order by one more simplified round from the
// accepted r_ (dx = J^{-1} r_ with the kept factors, p moved by Hess S_dt dx): by -(delta_x dx + delta_p Hess S_dt dx),
// delta's derivatives from the last Newton system (nearby). That round's move is mostly below the ulps of xb and p,
// which cannot hold it: moving them dropped it, and the accepted residual's part along the leaf stayed, a bias of the
// Casimirs; and a residual left by a correction of a few ulps of xb is that correction's rounding, the same way at
// every step, not round-off (docs/math.md 6). Not an iteration, and not tested again: the accepted residual is what
// the step reports.
void NewtonStepper::polish(Eigen::VectorXd& increment) {
    if (!solve(true) || !dx_.allFinite()) return;
    if (sparse_) {
        in_->gradient_.hessian.multiply(hessian_.data(), dx_, r_);
        const SparseRealisationValues& v = in_->sparse_values_;
        in_->realisation_.pattern_x().multiply(v.delta_x.data(), dx_, moved_);
        in_->realisation_.pattern_p().multiply(v.delta_p.data(), r_, gsize_);
        moved_ += gsize_;
    } else {
        in_->algebra_.product(hess_, dx_, r_);
        moved_.noalias() = in_->v_.delta_x * dx_;
        moved_.noalias() += in_->v_.delta_p * r_;
    }
    increment -= moved_;
}

// dx = J^{-1} r_ with the J just assembled (factored and kept), or with the kept factors (again): false when
// the sparse factorisation fails (J singular; the dense LU shows it as a non-finite dx).
bool NewtonStepper::solve(bool again) {
    if (sparse_) return again ? in_->matrix_.solve_again(r_, dx_) : in_->matrix_.solve(r_, dx_);
    if (again)
        in_->algebra_.solve_again(r_, dx_);
    else
        in_->algebra_.solve(J_, r_, dx_);
    return true;
}

// Newton from the predicted xb_: corrections until one is small (or stalls at round-off), then the
// acceptance test; a failed test goes on iterating. Near the solution (a correction below 1e-4 |x|) the
// next iterations are simplified Newton: the residual alone at the new base point (grad S_dt and alpha, the
// acceptance test's own evaluation, no Hessian, no derivatives of alpha) and the last Jacobian's LU, which
// contracts like Newton there (the error e0 e1 after e1: the Jacobian is off by O(e0)); a correction that
// does not halve brings the full Newton iteration back. The increment is delta at the accepted base point.
StepStatus NewtonStepper::newton(const Eigen::VectorXd& x, Eigen::VectorXd& increment, bool evaluated) {
    double previous = std::numeric_limits<double>::infinity(), previous_residual = previous, good_residual = previous,
           lambda = 1;
    const double x_norm = state_norm(x);
    bool simplified = false;
    for (int it = 1; it <= opt_.newton_max_iter; ++it) {
        if (simplified) {
            // r = alpha(xb, grad S_dt(xb)) - x, evaluated by the acceptance test itself
            if (accept_check(x, false)) return finish(x_norm, increment);
            if (!std::isfinite(residual_)) return StepStatus::non_finite;
            if (!solve(true)) return StepStatus::non_finite;
            xb_ -= dx_;
            iterations_ = it;
            const double correction = dx_.lpNorm<Eigen::Infinity>();
            if (!std::isfinite(correction)) return StepStatus::non_finite;
            simplified = newton_rules::stays_simplified(correction, correction_);
            correction_ = correction;
            previous = correction_, previous_residual = residual_;
            continue;
        }
        // r = alpha(xb, grad S_dt(xb)) - x;  J = alpha_x + alpha_p Hess S_dt (grad and Hess S_dt at the
        // predicted xb already in gh_ when evaluated: the batch step's)
        if (evaluated)
            take_gradient_at(xb_), evaluated = false;
        else
            evaluate_at(xb_);
        assemble();
        r_ = evaluated_alpha() - x;
        residual_ = r_.lpNorm<Eigen::Infinity>();
        // far from the solution (large steps) a full correction may overshoot: back along it (newton_rules)
        const double noise = newton_rules::noise(x_norm, state_norm(xb_));
        if (newton_rules::backtracks(residual_, good_residual, noise, lambda)) {
            lambda /= 2;
            xb_ = xb_good_ - lambda * dx_;
            continue;
        }
        if (!std::isfinite(residual_) || !evaluated_delta().allFinite()) return StepStatus::non_finite;
        good_residual = residual_, lambda = 1;
        xb_good_ = xb_;
        if (!solve(false)) return StepStatus::non_finite;  // J singular
        xb_ -= dx_;
        iterations_ = it;
        correction_ = dx_.lpNorm<Eigen::Infinity>();
        if (!std::isfinite(correction_)) return StepStatus::non_finite;
        const double scale = std::max(x_norm, state_norm(xb_));
        const bool small = newton_rules::small(correction_, opt_.newton_tol, scale);
        const bool settled = newton_rules::settled(small, correction_, previous, residual_, previous_residual);
        previous = correction_, previous_residual = residual_;
        if (settled && accept_check(x, small)) return finish(x_norm, increment);
        simplified = newton_rules::simplifies(in_->simplified_newton_, small, correction_, scale);
    }
    return StepStatus::newton_not_converged;
}

StepStatus NewtonStepper::step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment) {
    if (--native_countdown_ == 0) [[unlikely]]
        return sampled_step(x, dt, increment);
    return step_now(x, dt, increment);
}

StepStatus NewtonStepper::sampled_step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment) {
    native_countdown_ = native_sample_period;
    if (native_tier_ && native_tier_->settled()) adopt_native();
    if (!native_tier_) return step_now(x, dt, increment);
    const auto start = std::chrono::steady_clock::now();
    const StepStatus status = step_now(x, dt, increment);
    const auto spent = std::chrono::steady_clock::now() - start;
    const std::uint64_t left = expected_steps_;
    expected_steps_ -= std::min<std::uint64_t>(expected_steps_, native_sample_period);
    if (native_tier_->spend(native_sample_period * spent) || (left && native_tier_->repays(spent, left)))
        native_tier_->start(compiled_maps());
    return status;
}

void NewtonStepper::adopt_native() {
    if (!native_tier_ || !native_tier_->settled()) return;
    native_maps_ = native_tier_->attach(compiled_maps());
    native_failure_ = native_tier_->failure();
    native_tier_.reset();
}

// StepOptions::native at the build: always attaches now, automatic what the cache keeps (a tier for the rest); either
// writes machine code for the maps left without (series/machine_code.hpp).
void NewtonStepper::attach_native(NativePolicy policy) {
    if (policy == NativePolicy::never) return;
    const std::vector<CompiledMap*> maps = compiled_maps();
    const bool always = policy == NativePolicy::always;
    native_maps_ = info_.native_maps = always ? attach_native_code(maps) : attach_kept_native_code(maps);
    info_.machine_code_maps = attach_machine_code(maps);
    if (always || NativeTier::estimated_build_seconds(maps) == 0) return;  // (every map native, or empty)
    native_tier_ = std::make_shared<NativeTier>(maps);
    native_countdown_ = native_sample_period;
}

StepStatus NewtonStepper::step_now(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment) {
    if (lane_) return lane_step(x, dt, increment);
    if (!begin_step(x, dt)) return StepStatus::non_finite;
    in_->predictor_.eval(x, dt, xb_);
    return solve_from_prediction(x, increment, false);
}

StepStatus NewtonStepper::step_predicted(const Eigen::VectorXd& x, double dt, const double* xb, const double* gh,
                                         std::size_t stride, Eigen::VectorXd& increment) {
    if (!begin_step(x, dt)) return StepStatus::non_finite;
    for (Eigen::Index i = 0; i < xb_.size(); ++i) xb_[i] = xb[std::size_t(i) * stride];
    for (Eigen::Index i = 0; i < gh_.size(); ++i) gh_[i] = gh[std::size_t(i) * stride];
    return solve_from_prediction(x, increment, true);
}

// The step as LaneStep<N, double> takes it, its statistics copied to the stepper's.
StepStatus NewtonStepper::lane_step(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& increment) {
    StepStatus status = StepStatus::non_finite;
    if (increment.size() != x.size()) increment.resize(x.size());
    std::visit(
        [&](auto& lane) {
            constexpr Eigen::Index N = std::decay_t<decltype(lane)>::dimension;
            const Eigen::Index passive = x.size() - N;  // (a scheme's parameters: none, mostly)
            if (passive > 0) std::copy(x.data() + N, x.data() + x.size(), lane.passive());
            lane.step(*this, x.data(), dt, increment.data(), &status);
            if (passive > 0) increment.tail(passive).setZero();
            iterations_ = lane.iterations(0);
            residual_ = lane.residual(0), tolerance_ = lane.tolerance(0), ratio_ = lane.ratio(0);
            truncation_ = lane.truncation(0), correction_ = lane.correction(0);
            for (Eigen::Index i = 0; i < xb_.size(); ++i) xb_[i] = lane.base_point(std::size_t(i), 0);
            if (std::isfinite(dt)) step_dt_ = dt;
        },
        lane_->step);
    return status;
}

bool NewtonStepper::begin_step(const Eigen::VectorXd& x, double dt) {
    iterations_ = 0;
    residual_ = tolerance_ = ratio_ = truncation_ = 0;
    if (!x.allFinite() || !std::isfinite(dt)) return false;
    step_dt_ = dt;
    return true;
}

// Newton from the predicted xb_ (with grad and Hess S_dt there in gh_ when evaluated), and once more from xb = x
// if that fails.
StepStatus NewtonStepper::solve_from_prediction(const Eigen::VectorXd& x, Eigen::VectorXd& increment, bool evaluated) {
    const StepStatus first = newton(x, increment, evaluated);
    if (first == StepStatus::ok || first == StepStatus::truncation_above_bound || info_.predictor_order == 0)
        return first;
    // NOTE: far outside the predictor's range (stiff steps), Newton may still converge from xb = x.
    const int spent = iterations_;
    xb_ = x;
    const StepStatus second = newton(x, increment, false);
    iterations_ += spent;
    return second;
}

double NewtonStepper::residual_at_solution(const Eigen::VectorXd& x) {
    evaluate_at(xb_);  // at the last step's dt
    return (evaluated_alpha() - x).lpNorm<Eigen::Infinity>();
}

double NewtonStepper::residual_at(const Eigen::VectorXd& x, const Eigen::VectorXd& xb) {
    step_dt_ = dt_;
    in_->gradient_.gradient.eval(xb.data(), step_dt_, p_.data());
    in_->realisation_.check(xb, p_, in_->check_, /*with_delta=*/false);
    return (in_->check_.alpha - x).lpNorm<Eigen::Infinity>();
}

Eigen::MatrixXd NewtonStepper::tangent_map(const Eigen::VectorXd& x) {
    Eigen::VectorXd inc(x.size());
    if (step(x, inc) != StepStatus::ok) throw std::runtime_error("NewtonStepper::tangent_map: the step failed");
    Eigen::MatrixXd jacobian;
    last_step_jacobian(jacobian);  // poisson/step_jacobian.cpp
    return jacobian;
}

}  // namespace pgi
