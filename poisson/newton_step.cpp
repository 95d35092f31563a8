#include "poisson/newton_step.hpp"

#include "poisson/bisection.hpp"

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

// The degree of the next probe: where the terms' geometric decay, fitted on the last four, reaches
// the target, plus two for the parity of symmetric realisations; at least two more than now.
std::size_t deeper_probe(const std::vector<double>& a, double target, std::size_t max_degree) {
    const std::size_t top = a.size() - 1, lo = top >= 4 ? top - 3 : 1;
    std::size_t next = top + 2;
    if (a[lo] > 0 && a[top] > 0 && a[top] < a[lo]) {
        const double rho = std::pow(a[top] / a[lo], 1.0 / double(top - lo));
        next = std::max(next, top + static_cast<std::size_t>(std::ceil(std::log(target / a[top]) / std::log(rho))) + 2);
    }
    return std::min(next, max_degree + 1);
}

// The smallest D >= D_min whose neglected terms (two degrees at least, for the parity of symmetric
// realisations) are below round-off at the typical state; deepens the probe until one is found or
// max_degree is reached. Sets truncation to the size of the first neglected degree.
std::size_t choose_degree(const PoissonStructure& pi, const StepOptions& opt, std::size_t D_min, Realisation& probe,
                          const std::vector<double>& point, double scale, double& truncation) {
    const double target = unit_roundoff / 4;
    for (;;) {
        const auto a = component_sizes(probe, point, scale);
        for (std::size_t d = probe.degree - 2;; --d) {
            bool tail_small = true;
            for (std::size_t m = d + 1; m <= probe.degree; ++m) tail_small = tail_small && a[m] <= target;
            if (!tail_small) break;
            if (d == D_min || a[d] > target) {
                truncation = a[d + 1];
                return d;
            }
        }
        if (probe.degree >= opt.max_degree + 1) {
            truncation = a[opt.max_degree + 1];
            return opt.max_degree;
        }
        probe = build_realisation(pi, opt.realisation, deeper_probe(a, target, opt.max_degree));
    }
}

// One Newton iteration's cost in multiply-adds, roughly: grad and Hess of S_dt, the realisation with its
// derivatives, the LU solve, and a fixed 150 for what is not arithmetic (calls, pivoting, the update),
// which measured F+J times on the bundled scenes put at 100-200 predictor terms' worth.
double iteration_cost(const CompiledMap& gradient, const RealisationEvaluator& r, std::size_t n) {
    const double N = static_cast<double>(n);
    return static_cast<double>(gradient.num_terms() + gradient.num_monomials() + r.cost()) + N * N * N / 3 + 2 * N * N + 150;
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
// expecting one iteration, or once the predictor's terms alone cost more than the best choice so far.
// Deterministic: the choice depends on the scene only.
class PredictorChoice {
public:
    PredictorChoice(const StepOptions& opt, double iteration_cost, std::vector<double> point, double scale)
        : opt_(opt), iteration_cost_(iteration_cost), point_(std::move(point)), scale_(scale),
          limit_(std::max<std::size_t>(opt.k + 1, 8)) {}
    bool operator()(const std::vector<Series>& v) {
        const std::size_t s = v.front().order() - 1;  // exact through dt^s: scores the order P = s - 1
        double e = 0, terms = 0;
        for (const auto& vl : v) {
            e = std::max(e, std::abs(std::pow(opt_.dt, double(s)) * evaluate(vl[s], point_)) / scale_);
            for (std::size_t m = 1; m < s; ++m) terms += static_cast<double>(vl[m].length());
        }
        const int iterations = expected_iterations(e, opt_.newton_tol);
        const double cost = terms + iterations * iteration_cost_;
        if (!best_ || cost < best_cost_) best_ = s - 1, best_cost_ = cost;
        // higher orders only add terms once one iteration suffices, or once the terms alone cost more
        return iterations == 1 || terms >= best_cost_ || s >= limit_ + 1;
    }
    std::size_t order() const { return best_.value_or(0); }

private:
    const StepOptions& opt_;
    double iteration_cost_;
    std::vector<double> point_;
    double scale_;
    std::size_t limit_;
    std::optional<std::size_t> best_;
    double best_cost_ = 0;
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
    const bool closed = realisation_form(cls, opt.realisation) != RealisationForm::radial;
    // the predictor's order: as asked, or chosen below among 0..max(k + 1, 8) (which needs one order more)
    const std::size_t P_limit = opt.predictor_order ? opt.predictor_order : std::max<std::size_t>(opt.k + 1, 8);
    const std::size_t P = opt.predictor_order ? P_limit : P_limit + 1;

    // S_1..S_k need the realisation through degree k - 1, the predictor through degree P.
    const std::size_t D_min = std::max<std::size_t>(realisation_degree_for_order(opt.k), 1);
    std::size_t probe_degree = std::max(D_min, P) + 2;
    Realisation probe = build_realisation(pi, opt.realisation, probe_degree);
    auto S = hamilton_jacobi_terms(M, probe, H, opt.k);
    Poly S_dt = sum_powers(S, dt, 1);  // S_dt = sum_j dt^j S_j, exactly in the double dt

    // p at the typical state, to size the realisation's terms there.
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    Eigen::VectorXd p0(static_cast<Eigen::Index>(n));
    for (std::size_t l = 0; l < n; ++l)
        p0[static_cast<Eigen::Index>(l)] = evaluate(derivative(S_dt, M.x(l)), phase_point(x_typical, zero));
    const double scale = std::max(x_typical.lpNorm<Eigen::Infinity>(), std::numeric_limits<double>::min());
    const auto point = phase_point(x_typical, p0);

    if (closed && cls == StructureClass::log_canonical) {
        s.info_ = {probe.method + " (closed form)", 0, true, 0.0, 0};
        s.realisation_ = RealisationEvaluator::log_canonical(pi);
    } else if (closed && cls == StructureClass::linear && RealisationEvaluator::has_rotation_form(pi)) {
        s.info_ = {probe.method + " (closed form, so(3))", 0, true, 0.0, 0};
        s.realisation_ = RealisationEvaluator::rotation(pi);
    } else {
        const std::size_t D = choose_degree(pi, opt, D_min, probe, point, scale, s.info_.truncation_estimate);
        Realisation used = truncated(probe, D);
        s.info_.method = used.method;
        s.info_.degree = D;
        s.info_.exact_realisation = cls == StructureClass::constant && closed;
        s.realisation_ = closed && cls == StructureClass::linear ? RealisationEvaluator::lie_poisson(pi, D)
                                                                 : RealisationEvaluator::polynomial(pi, used);
    }

    // grad S_dt and its Hessian, column-major.
    std::vector<Poly> g;
    for (std::size_t l = 0; l < n; ++l) g.push_back(derivative(S_dt, M.x(l)));
    for (std::size_t c = 0; c < n; ++c)
        for (std::size_t r = 0; r < n; ++r) g.push_back(derivative(g[c], M.x(r)));
    s.gradient_ = CompiledMap::build(g, M.coordinate_vars());

    // xb = x + sum_m dt^m u_m, from the exact series of the base point, to the order chosen.
    PredictorChoice choice(opt, iteration_cost(s.gradient_, s.realisation_, n), phase_point(x_typical, zero), scale);
    auto u = opt.predictor_order ? base_point_series(M, probe, S, P) : base_point_series(M, probe, S, P, std::ref(choice));
    s.info_.predictor_order = opt.predictor_order ? P : choice.order();
    std::vector<Poly> xb;
    for (std::size_t l = 0; l < n; ++l) {
        std::vector<Poly> c;
        for (std::size_t m = 0; m < s.info_.predictor_order; ++m) c.push_back(u[m][l]);
        xb.push_back(c.empty() ? M.x_gen(l) : M.x_gen(l) + sum_powers(c, dt, 1));
    }
    s.predictor_ = CompiledMap::build(xb, M.coordinate_vars());

    const auto N = static_cast<Eigen::Index>(n);
    s.v_ = RealisationValues(n);
    s.xb_.setZero(N);
    s.p_.setZero(N);
    s.r_.setZero(N);
    s.dx_.setZero(N);
    s.gh_.setZero(N + N * N);
    s.hess_.setZero(N, N);
    s.J_.setZero(N, N);
    s.D_.setZero(N, N);
    s.lu_ = Eigen::PartialPivLU<Eigen::MatrixXd>(N);
    return s;
}

void NewtonStepper::evaluate_at(const Eigen::VectorXd& xb) {
    const auto n = xb.size();
    gradient_.eval(xb.data(), gh_.data());
    p_ = gh_.head(n);
    hess_ = Eigen::Map<const Eigen::MatrixXd>(gh_.data() + n, n, n);
    realisation_.eval(xb, p_, v_);
}

const Eigen::MatrixXd& NewtonStepper::newton_system(const Eigen::VectorXd& xb) {
    evaluate_at(xb);
    J_ = v_.alpha_x;
    J_.noalias() += v_.alpha_p * hess_;
    return J_;
}

bool NewtonStepper::newton(const Eigen::VectorXd& x, Eigen::VectorXd& increment) {
    const double scale = x.lpNorm<Eigen::Infinity>();
    for (int it = 1; it <= opt_.newton_max_iter; ++it) {
        // r = alpha(xb, grad S_dt(xb)) - x;  J = alpha_x + alpha_p Hess S_dt
        newton_system(xb_);
        r_ = v_.alpha - x;
        residual_ = r_.lpNorm<Eigen::Infinity>();
        if (!std::isfinite(residual_) || !v_.delta.allFinite()) return false;
        solve(J_, r_, dx_, lu_);
        xb_ -= dx_;
        iterations_ = it;
        correction_ = dx_.lpNorm<Eigen::Infinity>();
        if (!std::isfinite(correction_)) return false;
        if (correction_ <= opt_.newton_tol * scale) {
            // delta at the corrected base point, to first order: the remainder is O(|dx|^2)
            D_ = v_.delta_x;
            D_.noalias() += v_.delta_p * hess_;
            increment = v_.delta;
            increment.noalias() -= D_ * dx_;
            return increment.allFinite();
        }
    }
    return false;
}

StepStatus NewtonStepper::step(const Eigen::VectorXd& x, Eigen::VectorXd& increment) {
    iterations_ = 0;
    if (!x.allFinite()) return StepStatus::non_finite;
    predictor_.eval(x.data(), xb_.data());
    if (newton(x, increment)) return StepStatus::ok;
    // NOTE: far outside the predictor's range (stiff steps), Newton may still converge from xb = x.
    const int first = iterations_;
    xb_ = x;
    const bool ok = newton(x, increment);
    iterations_ += first;
    if (ok) return StepStatus::ok;
    return std::isfinite(residual_) ? StepStatus::newton_not_converged : StepStatus::non_finite;
}

double NewtonStepper::residual_at_solution(const Eigen::VectorXd& x) {
    evaluate_at(xb_);
    return (v_.alpha - x).lpNorm<Eigen::Infinity>();
}

Eigen::MatrixXd NewtonStepper::tangent_map(const Eigen::VectorXd& x) {
    Eigen::VectorXd inc(x.size());
    if (step(x, inc) != StepStatus::ok) throw std::runtime_error("NewtonStepper::tangent_map: the step failed");
    newton_system(xb_);
    D_ = v_.delta_x;
    D_.noalias() += v_.delta_p * hess_;
    // x = alpha(xb(x)) gives dxb/dx = J^{-1}; x_new = beta(xb) = alpha + delta, so Dphi = (J + D) J^{-1}
    return Eigen::MatrixXd::Identity(x.size(), x.size()) + D_ * J_.inverse();
}

}  // namespace pgi
