#include "poisson/predictor.hpp"

#include "poisson/detail/bisection.hpp"
#include "poisson/detail/newton_rules.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <set>

namespace pgi {

namespace {

// How many of n coordinates end the list and stay put (moves(v) false for each): a scheme's parameters, which the
// predictor's map reads through its coefficients. The one rule of Predictor::build and of the choice's cost.
template <class Moves>
std::size_t still_at_end(std::size_t n, Moves moves) {
    std::size_t still = 0;
    while (still < n && !moves(n - 1 - still)) ++still;
    return still;
}

// The coordinates before those still_at_end through dt^s.
std::size_t moving_coordinates(const std::vector<Series>& v, std::size_t s) {
    return v.size() - still_at_end(v.size(), [&](std::size_t i) {
               for (std::size_t m = 1; m <= s; ++m)
                   if (!v[i][m].is_zero()) return true;
               return false;
           });
}

// The terms the predictor's map evaluates for f, a polynomial in n coordinates (coordinate i is ring variable i): its
// monomials in the first `moving` coordinates, the others' powers being read through the coefficients.
double evaluated_terms(const Poly& f, std::size_t moving, std::size_t n) {
    if (moving == n) return static_cast<double>(f.length());
    std::set<std::vector<unsigned long>> monomials;
    for (std::size_t i = 0; i < f.length(); ++i) {
        std::vector<unsigned long> e = f.term_exponents(i);
        e.resize(moving);
        monomials.insert(std::move(e));
    }
    return static_cast<double>(monomials.size());
}

// The predictor order P minimising (terms of the predictor) + Newton's expected cost (NewtonCost::from) from a
// start off by the first neglected term dt^(P+1) u_(P+1) at the typical state. Fed the base point's series order
// by order (base_point_series' `enough`); stops at the first order whose start is within newton_tol, or once
// the next orders cannot win or cost more exact work than they save.
// Deterministic: the choice depends on the scene only.
class PredictorChoice {
public:
    static constexpr double cheap_order_terms = 500;
    /// cap_stops: whether an order above cheap_order_terms stops the choice (not in the first pass, whose
    /// orders are computed anyway).
    PredictorChoice(const StepOptions& opt, const NewtonCost& cost, std::vector<double> point, double scale,
                    std::size_t limit, bool cap_stops = true)
        : opt_(opt), cost_(cost), point_(std::move(point)), scale_(scale), limit_(limit), cap_stops_(cap_stops) {}
    bool operator()(const std::vector<Series>& v) {
        const std::size_t s = v.front().order() - 1;  // exact through dt^s: scores the order P = s - 1
        const std::size_t moving = moving_coordinates(v, s);
        double e = 0, terms = 0, top = 0, top_exact = 0;
        for (const auto& vl : v) {
            e = std::max(e, std::abs(std::pow(opt_.dt, double(s)) * evaluate(vl[s], point_)) / scale_);
            for (std::size_t m = 1; m < s; ++m) terms += evaluated_terms(vl[m], moving, v.size());
            top += evaluated_terms(vl[s], moving, v.size());
            top_exact += static_cast<double>(vl[s].length());
        }
        const double cost = terms + cost_.from(e, opt_.newton_tol);
        if (!best_ || cost < best_cost_) best_ = s - 1, best_cost_ = cost;
        // Every order costs at least one iteration: the next (terms + top) wins only below best - one
        // iteration; none wins past a start within newton_tol. An order computed from more than
        // cheap_order_terms new terms costs several times the last in exact work (seconds from ~2000 terms in
        // 6 variables: e(3)* k = 4 spent 26 s on orders 6-7 to save one iteration in two), more than a run
        // saves: the choice stays among the cheap orders.
        // A first neglected term that does not shrink means the series diverges at this dt.
        const bool hopeless = terms + top >= best_cost_ - cost_.full;
        const bool diverging = e_ > 0 && e >= e_;
        const bool capped = top_exact > cheap_order_terms;
        capped_ = capped_ || capped;
        const bool decided = e <= opt_.newton_tol || hopeless || (capped && cap_stops_) || diverging;
        at_limit_ = !decided && s >= limit_ + 1;
        e_ = e;
        return decided || s >= limit_ + 1;
    }
    std::size_t order() const { return best_.value_or(0); }
    /// Whether only the limit stopped the choice, every order seen within the cap: a higher limit could go on.
    bool at_limit() const { return at_limit_ && !capped_; }

private:
    const StepOptions& opt_;
    NewtonCost cost_;
    std::vector<double> point_;
    double scale_;
    std::size_t limit_;
    std::optional<std::size_t> best_;
    double best_cost_ = 0;
    double e_ = 0;  // of the order before
    bool cap_stops_;
    bool at_limit_ = false, capped_ = false;
};

}  // namespace

std::size_t predictor_limit(const StepOptions& opt) {
    return opt.predictor_order ? opt.predictor_order : std::max<std::size_t>(opt.k + 1, 8) + 1;
}

std::size_t predictor_first_pass(const StepOptions& opt) {
    return opt.predictor_order ? predictor_limit(opt) : std::min<std::size_t>(predictor_limit(opt), 3);
}

NewtonCost newton_cost(std::size_t system_cost, std::size_t residual_cost, double factor_cost, double solve_cost,
                       bool simplified) {
    return {static_cast<double>(system_cost) + factor_cost + solve_cost + 150, static_cast<double>(residual_cost),
            solve_cost + 150, simplified};
}

// Newton from a start off by e, as NewtonStepper::newton runs it: a full iteration corrects by about the error and
// leaves its square; a correction within newton_tol ends the step (p updated by the Hessian). Above it, from
// corrections within simplified_from, simplified Newton runs the acceptance test with grad S_dt anew, then a solve
// with the kept factors, which multiplies the error by the kept J's own error (the error where J was evaluated).
// The model counts the test as passed once the error left is below u: from e <= sqrt(u) ~ 1e-8, one iteration and
// that test. (The test itself passes up to kappa u, e up to 3e-7 on Lotka-Volterra, but that tolerance is for the
// evaluation's round-off: steps accepted there drift a Casimir by tens of ulps a step; Lotka-Volterra's drifted
// 3.6e-13 in 1e5 steps instead of below 1e-13.) Lotka-Volterra at k = 12, dt = 0.2: counting full iterations to
// newton_tol (1e-9) instead, the choice took P = 4 and two iterations there, 570 ns a step against 410-430 for
// P = 8-10 and one.
double NewtonCost::from(double e, double newton_tol) const {
    double cost = full, left = e * e, kept = e;  // the first full iteration, the error it leaves, its J's error
    bool small = e <= newton_tol;
    for (int round = 1; !small && round < 8; ++round) {
        if (simplified && kept <= simplified_from) {
            cost += check;
            if (left <= unit_roundoff) break;
            cost += kept_solve;
            left *= kept;
        } else {
            cost += full;
            small = left <= newton_tol;
            kept = left, left *= left;
        }
    }
    return cost;
}

Predictor Predictor::build(const PhaseSpace& M, const std::vector<std::vector<Poly>>& u, double planned_dt) {
    Predictor p;
    p.order_ = u.size();
    p.dim_ = M.dim();
    // the coordinates that end the list and the series leaves alone (a scheme's parameters: constant along a run) are
    // read through the coefficients
    const auto moves = [&](std::size_t v) {
        return std::any_of(u.begin(), u.end(), [v](const std::vector<Poly>& uj) { return !uj[v].is_zero(); });
    };
    const std::size_t slow = u.empty() ? 0 : still_at_end(M.dim(), moves);
    p.map_ = DtSeriesMap::build(u, M.coordinate_vars(), planned_dt, slow);
    return p;
}

Predictor Predictor::choose(const PhaseSpace& M, const Realisation& probe, const std::vector<Poly>& S,
                            const StepOptions& opt, const NewtonCost& cost, const Eigen::VectorXd& x_typical,
                            double scale, const RealisationSource& deeper) {
    if (opt.predictor_order)
        return build(M, base_point_series(M, probe, S, std::min(predictor_limit(opt), probe.degree)), opt.dt);
    const std::vector<double> point =
        M.point(std::span<const double>(x_typical.data(), std::size_t(x_typical.size())));  // (the series read no p)
    // The series is computed to the limit's order before the choice sees it, and at large n (the lattices) every
    // order holds O(n) terms: a first pass scores the orders through predictor_first_pass (all of them, whatever
    // their size), and the full limit is computed only when that limit alone stopped the choice within the cap
    // (then it decides exactly as one pass would).
    const std::size_t P1 = std::min(predictor_first_pass(opt), probe.degree);
    std::optional<PredictorChoice> choice;
    choice.emplace(opt, cost, point, scale, P1 - 1, false);
    auto u = base_point_series(M, probe, S, P1, std::ref(*choice));
    const std::size_t P = std::min(predictor_limit(opt), deeper ? predictor_limit(opt) : probe.degree);
    if (choice->at_limit() && P1 < P) {
        const RealisationPtr deeper_one = probe.degree >= P ? nullptr : deeper(P);
        const Realisation& deep = deeper_one ? *deeper_one : probe;
        choice.emplace(opt, cost, point, scale, P - 1);
        u = base_point_series(M, deep, S, P, std::ref(*choice));
    }
    u.resize(std::min(u.size(), choice->order()), std::vector<Poly>{});
    return build(M, u, opt.dt);
}

void Predictor::eval(const double* x, double dt, double* xb) const {
    if (order_ == 0) {
        std::copy(x, x + dim_, xb);
        return;
    }
    map_.eval(x, dt, xb);
    for (std::size_t i = 0; i < dim_; ++i) xb[i] += x[i];
}

void Predictor::eval_batch(const double* X, double dt, double* XB, std::size_t m, BatchScratch& scratch) const {
    const std::size_t size = dim_ * m;
    if (order_ == 0) {
        std::copy(X, X + size, XB);
        return;
    }
    map_.eval_batch(X, dt, XB, m, scratch);
    for (std::size_t i = 0; i < size; ++i) XB[i] += X[i];
}

}  // namespace pgi
