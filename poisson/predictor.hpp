#pragma once
// The Newton predictor (docs/math.md 6): the base point's exact series in dt, xb = x + sum_{m=1..P} dt^m u_m(x),
// its order P chosen by a cost model at the build's dt, the u_m compiled stacked (dt a run-time argument).
#include "poisson/dt_series.hpp"
#include "poisson/step_options.hpp"

#include <Eigen/Dense>

#include <functional>

namespace pgi {

/// The longest series the build computes: opt.predictor_order if given, else max(k + 1, 8) + 1 (the
/// choice scores order P from the series through dt^(P+1), its first neglected term).
std::size_t predictor_limit(const StepOptions& opt);
/// The orders the choice scores first, before any deeper series is computed (predictor_limit if the order is asked).
std::size_t predictor_first_pass(const StepOptions& opt);

/// What Newton costs in multiply-adds, roughly, for the predictor's cost model: a full iteration (one
/// evaluation of the Newton system: grad and Hess of S_dt, the realisation with its derivatives; the
/// factorisation and solve of J; and a fixed 150 for what is not arithmetic (calls, pivoting, the update),
/// which measured F+J times on the bundled scenes put at 100-200 predictor terms' worth), the acceptance test
/// with grad S_dt evaluated anew (the residual alone), which follows a correction above newton_tol, and a
/// solve with the kept factors (with its 150); simplified: whether the stepper runs simplified Newton (a
/// round of it is the test and a kept solve), else every iteration is a full one.
struct NewtonCost {
    double full = 0, check = 0, kept_solve = 0;
    bool simplified = false;
    /// Newton's expected cost from a start of relative error e (docs/math.md 6).
    double from(double e, double newton_tol) const;
};
NewtonCost newton_cost(std::size_t system_cost, std::size_t residual_cost, double factor_cost, double solve_cost,
                       bool simplified);

class Predictor {
public:
    Predictor() = default;
    /// u[m - 1] = u_m, one polynomial per coordinate (P = u.size(); P = 0 predicts xb = x); planned_dt as
    /// for DtSeriesMap.
    static Predictor build(const PhaseSpace& M, const std::vector<std::vector<Poly>>& u, double planned_dt = 0);
    /// The series of the base point of the truncated realisation probe and S_1..S_k, to the order asked
    /// (opt.predictor_order) or else to the order P <= min(predictor_limit - 1, probe.degree - 1) minimising
    /// the predictor's terms plus the Newton iterations it leaves at (x_typical, opt.dt) at their cost, its error
    /// relative to scale (the size of x_typical's moving coordinates, NewtonStepper's).
    /// deeper (closed forms): the realisation through a degree beyond probe's, asked only if the choice goes past
    /// predictor_first_pass; without it the orders stop at probe.degree - 1.
    static Predictor choose(const PhaseSpace& M, const Realisation& probe, const std::vector<Poly>& S,
                            const StepOptions& opt, const NewtonCost& cost, const Eigen::VectorXd& x_typical,
                            double scale, const RealisationSource& deeper = {});

    std::size_t order() const { return order_; }
    /// sum_m dt^m u_m (eval adds x to it).
    const DtSeriesMap& series() const { return map_; }
    DtSeriesMap& series() { return map_; }
    /// xb = x + sum_m dt^m u_m(x). Allocates nothing.
    void eval(const Eigen::VectorXd& x, double dt, Eigen::VectorXd& xb) const { eval(x.data(), dt, xb.data()); }
    /// The same on dim() values (xb and x do not overlap).
    void eval(const double* x, double dt, double* xb) const;
    /// m states at once, structure of arrays (X[v m + j], XB likewise), each bit for bit eval()'s.
    void eval_batch(const double* X, double dt, double* XB, std::size_t m, BatchScratch& scratch) const;

private:
    DtSeriesMap map_;
    std::size_t order_ = 0;
    std::size_t dim_ = 0;
};

}  // namespace pgi
