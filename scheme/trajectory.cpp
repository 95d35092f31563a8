#include "scheme/trajectory.hpp"

#include "poisson/integrate.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pgi {

std::size_t steps_to_reach(double t_end, double dt) { return static_cast<std::size_t>(std::ceil(t_end / dt - 1e-9)); }

double term_size(const Poly& f, std::span<const double> x) {
    double s = 0;
    for (std::size_t t = 0; t < f.length(); ++t) {
        double c = std::abs(f.term_coeff(t).to_double());
        const auto e = f.term_exponents(t);
        for (std::size_t v = 0; v < x.size() && v < e.size(); ++v)
            if (e[v] != 0) c *= std::pow(std::abs(x[v]), double(e[v]));
        s += c;
    }
    return s;
}

std::vector<double> invariant_scales(const Scheme& scheme, std::span<const double> x, const std::vector<Poly>& extra) {
    std::vector<double> out{term_size(scheme.hamiltonian(), x)};
    for (const auto& C : scheme.casimirs()) out.push_back(term_size(C, x));
    for (const auto& f : extra) out.push_back(term_size(f, x));
    return out;
}

double relative_error(double value, double initial, double scale) {
    const double d = std::abs(value - initial);
    return scale > 0 ? d / scale : d;
}

std::string step_failure_message(const NewtonStepper& s, std::size_t step, StepStatus status) {
    char buffer[512];
    std::snprintf(buffer, sizeof buffer,
                  "step %zu (from t = %.17g) failed: %s after %d Newton iterations, residual %.3g, last correction %.3g; "
                  "a smaller dt may help", step,
                  double(step - 1) * s.dt(), to_string(status).c_str(), s.last_iterations(), s.last_residual(),
                  s.last_correction());
    return buffer;
}

Trajectory integrate(const Scheme& scheme, const Eigen::VectorXd& x0, double dt, double t_end, std::size_t every,
                     const std::optional<Eigen::VectorXd>& x_typical) {
    const std::size_t n = scheme.phase_space().dim();
    if (every == 0) throw std::invalid_argument("every must be at least 1");
    if (!(t_end >= 0) || !std::isfinite(t_end)) throw std::invalid_argument("t_end must be finite and not negative");
    if (!(dt > 0) || !std::isfinite(dt)) throw std::invalid_argument("dt must be positive and finite");
    if (static_cast<std::size_t>(x0.size()) != n || !x0.allFinite())
        throw std::invalid_argument("x0 must have " + std::to_string(n) + " finite values");
    if (x_typical && (x_typical->size() != x0.size() || !x_typical->allFinite()))
        throw std::invalid_argument("x_typical must have " + std::to_string(n) + " finite values");
    NewtonStepper stepper = scheme.stepper(dt, x_typical ? *x_typical : x0);
    const std::size_t N = steps_to_reach(t_end, dt), C = scheme.casimirs().size();
    CompiledMap inv = scheme.invariants();
    std::vector<double> values(inv.num_outputs()), initial(inv.num_outputs()), worst(inv.num_outputs(), 0.0);
    const std::vector<double> scale = invariant_scales(scheme, std::span<const double>(x0.data(), n));
    Trajectory r;
    r.dim = n;
    Eigen::VectorXd x = x0;
    auto summary = integrate_steps(stepper, x, N, [&](std::size_t step, double t, const Eigen::VectorXd& y) {
        inv.eval(y.data(), values.data());
        if (step == 0) initial = values;
        for (std::size_t i = 0; i < values.size(); ++i) worst[i] = std::max(worst[i], relative_error(values[i], initial[i], scale[i]));
        r.newton_iterations_max = std::max(r.newton_iterations_max, step ? stepper.last_iterations() : 0);
        if (step % every == 0 || step == N) {
            r.t.push_back(t);
            r.x.insert(r.x.end(), y.data(), y.data() + y.size());
            r.energy_error.push_back(relative_error(values[0], initial[0], scale[0]));
            for (std::size_t c = 0; c < C; ++c) r.casimir_error.push_back(relative_error(values[1 + c], initial[1 + c], scale[1 + c]));
        }
        return false;
    });
    r.steps = summary.steps;
    r.status = summary.status;
    r.newton_iterations_mean = summary.mean_iterations;
    r.energy_error_max = worst[0];
    r.casimir_error_max.assign(worst.begin() + 1, worst.begin() + 1 + long(C));
    if (summary.status != StepStatus::ok) {
        r.failed_step = summary.steps + 1;
        r.failed_t = double(summary.steps) * dt;
        r.failed_residual = stepper.last_residual();
        r.message = step_failure_message(stepper, r.failed_step, summary.status);
    }
    return r;
}

}  // namespace pgi
