// Cost of the step's tangent map (poisson/step_jacobian.hpp) against the step itself: on each scene at its dt
// and order, along the first STEPS states of its orbit, the median time per call (7 repetitions) of the step alone and
// of the step followed by its Jacobian (NewtonStepper::last_step_jacobian), and their ratios, measured in the same run.
// Prints one JSON object per scene. Usage: pgi_bench_tangent SCENE... [--steps STEPS] (default 20000)
#include "poisson/step_jacobian.hpp"
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

// Median over 7 repetitions of the time per call of fn(i), i over `calls` states, in ns.
template <class F>
double median_ns(F&& fn, std::size_t calls) {
    std::vector<double> t;
    for (int rep = 0; rep < 7; ++rep) {
        const auto t0 = Clock::now();
        for (std::size_t i = 0; i < calls; ++i) fn(i);
        t.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / double(calls));
    }
    std::nth_element(t.begin(), t.begin() + 3, t.end());
    return t[3];
}

nlohmann::json measure(const std::string& path, std::size_t steps) {
    const pgi::Scene scene = pgi::load_scene(path);
    // the scene's x0, else (and past its coordinates) values in [1/2, 3/2], as the tests take them
    Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(Eigen::Index(scene.phase_space().dim()), 0.5, 1.5);
    if (scene.x0)
        x.head(Eigen::Index(scene.x0->size())) =
            Eigen::Map<const Eigen::VectorXd>(scene.x0->data(), Eigen::Index(scene.x0->size()));
    pgi::NewtonStepper st = scene.scheme->stepper(scene.dt, x);
    std::vector<Eigen::VectorXd> states;  // the orbit: each call steps from one of its states
    Eigen::VectorXd inc(x.size());
    for (std::size_t i = 0; i < steps; ++i) {
        states.push_back(x);
        if (st.step(x, inc) != pgi::StepStatus::ok) throw std::runtime_error(path + ": a step failed");
        x += inc;
    }
    Eigen::MatrixXd J(x.size(), x.size());
    double sink = 0;
    const double step_ns = median_ns(
        [&](std::size_t i) {
            (void)st.step(states[i], inc);
            sink += inc[0];
        },
        steps);
    const double tangent_ns = median_ns(
        [&](std::size_t i) {
            (void)st.step(states[i], inc);
            st.last_step_jacobian(J);
            sink += J(0, 0);
        },
        steps);
    return {{"scene", scene.name},
            {"n", x.size()},
            {"order", scene.order},
            {"dt", scene.dt},
            {"method", st.info().method},
            {"step_ns", step_ns},
            {"step_and_jacobian_ns", tangent_ns},
            {"jacobian_over_step", (tangent_ns - step_ns) / step_ns},
            {"step_and_jacobian_over_step", tangent_ns / step_ns},
            {"sink", sink != sink ? 0.0 : 1.0}};
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t steps = 20000;
    std::vector<std::string> scenes;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--steps" && i + 1 < argc)
            steps = std::stoul(argv[++i]);
        else
            scenes.push_back(a);
    }
    if (scenes.empty()) {
        std::cerr << "usage: pgi_bench_tangent SCENE... [--steps STEPS]\n";
        return 2;
    }
    for (const auto& s : scenes) std::cout << measure(s, steps).dump() << std::endl;
    return 0;
}
