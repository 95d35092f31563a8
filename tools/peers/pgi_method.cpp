// pgi as a method of the comparison, through its documented C++ API (Scheme, stepper, integrate_steps): the stepper
// is built (exact phase, compilation) before the clock starts; that time is reported apart, as setup_seconds.
// Repeated runs (best_of) step on one stepper.
#include "poisson/integrate.hpp"
#include "tools/commands.hpp"
#include "tools/peers/methods.hpp"

#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <optional>

namespace pgi::peers {

namespace {

// The stepper at order k and step dt for starts near x0, built now through pgi's C++ API as a user builds it: a Scheme
// of the scene's problem at order k in its default configuration (the realisation the scene names, automatic by
// default; native code as NativePolicy::automatic decides: a library the JIT cache keeps at once, else machine code
// until the step's time pays for a build in the background), or for the "-jit" variant NativePolicy::always (native
// code built now, in the set-up); then scheme.stepper(dt, x0). Runs from any x0 to T on it: integrate_steps
// (stepper.step and Kahan summation), watching the invariants only when the problem is monitoring; each outcome says
// how many of the step's maps ran native code at its end (native_maps).
PreparedRun prepare_pgi(const Problem& pr, const State& x0, double dt, std::size_t k, RealisationChoice realisation,
                        bool jit) {
    const auto setup = Clock::now();
    pr.scene.phase_space().ring()->budget().restart();  // each stepper's exact phase has the whole time budget
    // the problem at order k, kept beside its stepper; a Scheme of its own per (k, dt), as a program run at that dt
    auto scheme = std::make_shared<const Scheme>(
        pr.scene.pi, pr.scene.H, pr.scene.casimirs, k, realisation,
        /*trust_jacobi=*/false, jit ? NativePolicy::always : NativePolicy::automatic, pr.scene.parameters);
    auto stepper = std::make_shared<NewtonStepper>(
        scheme->stepper(dt, Eigen::Map<const Eigen::VectorXd>(x0.data(), Eigen::Index(x0.size()))));
    const double setup_seconds = std::chrono::duration<double>(Clock::now() - setup).count();
    return [&pr, scheme, stepper, dt, setup_seconds](const State& start, double T, Samples* samples) {
        Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(start.data(), Eigen::Index(start.size()));
        pr.evaluations = 0;
        Monitor monitor(pr, start.data(), samples);
        const auto N = static_cast<std::size_t>(std::llround(T / dt));
        const bool monitoring = pr.monitoring;
        const auto clock = Clock::now();
        const auto summary =
            monitoring
                ? integrate_steps(*stepper, x, N,
                                  [&](std::size_t n, double t, const Eigen::VectorXd& y) {
                                      if (n > 0) monitor(t, y.data());
                                      return false;
                                  })
                : integrate_steps(*stepper, x, N, [](std::size_t, double, const Eigen::VectorXd&) { return false; });
        const std::string failure =
            summary.status == StepStatus::ok ? "" : failure_message(*stepper, summary.steps + 1, summary.status);
        Outcome o = finish(State(x.data(), x.data() + x.size()), summary.steps, clock, monitor, failure);
        o.evaluations =
            static_cast<std::size_t>(std::llround(summary.mean_iterations * double(summary.steps)));  // Newton systems
        o.setup_seconds = setup_seconds;
        o.native_maps = stepper->native_maps();
        return o;
    };
}

}  // namespace

Method pgi_method(std::size_t k, std::optional<RealisationChoice> realisation, bool jit) {
    const std::string name =
        (realisation ? fmt::format("pgi-k{}-{}", k, to_string(*realisation)) : fmt::format("pgi-k{}", k)) +
        (jit ? "-jit" : "");
    const auto prepare = [k, realisation, jit](const Problem& pr, const State& x0, double dt) {
        return prepare_pgi(pr, x0, dt, k, realisation.value_or(pr.scene.realisation), jit);
    };
    return {name, true,
            [prepare](const Problem& pr, const State& x0, double T, double dt, Samples* samples) {
                return prepare(pr, x0, dt)(x0, T, samples);
            },
            prepare};
}

}  // namespace pgi::peers
