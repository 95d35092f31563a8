// pgi as a method of the comparison: the stepper is built (exact phase, compilation) before the clock
// starts; that time is reported apart, as setup_seconds.
#include "poisson/integrate.hpp"
#include "tools/commands.hpp"
#include "tools/peers/methods.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>

namespace pgi::peers {

Method pgi_method(std::size_t k, std::optional<RealisationChoice> realisation, bool jit) {
    const std::string name = (realisation ? fmt::format("pgi-k{}-{}", k, to_string(*realisation)) : fmt::format("pgi-k{}", k)) + (jit ? "-jit" : "");
    return {name, true, [k, realisation, jit](const Problem& pr, const State& x0, double T, double dt, Samples* samples) {
                StepOptions opt;
                opt.k = k;
                opt.dt = dt;
                opt.jit = jit;
                opt.realisation = realisation.value_or(pr.scene.realisation);
                Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(x0.data(), Eigen::Index(x0.size()));
                const auto setup = Clock::now();
                pr.scene.phase_space().ring()->budget().restart();  // each stepper's exact phase has the whole time budget
                const Scheme scheme(pr.scene.pi, pr.scene.H, pr.scene.casimirs, k, opt.realisation);  // the problem at order k
                auto stepper = scheme.stepper(opt, x);
                const double setup_seconds = std::chrono::duration<double>(Clock::now() - setup).count();
                pr.evaluations = 0;
                Monitor monitor(pr, x0.data(), samples);
                const auto N = static_cast<std::size_t>(std::llround(T / dt));
                const auto start = Clock::now();
                const auto summary = integrate_steps(stepper, x, N, [&](std::size_t n, double t, const Eigen::VectorXd& y) {
                    if (n > 0) monitor(t, y.data());
                    return false;
                });
                const std::string failure =
                    summary.status == StepStatus::ok ? "" : failure_message(stepper, summary.steps + 1, summary.status);
                Outcome o = finish(State(x.data(), x.data() + x.size()), summary.steps, start, monitor, failure);
                o.evaluations = static_cast<std::size_t>(std::llround(summary.mean_iterations * double(summary.steps)));  // Newton systems
                o.setup_seconds = setup_seconds;
                return o;
            }};
}

}  // namespace pgi::peers
