// Speed of the compiled step: ns per step for k = 1..6 on a scene at its default dt, the mean Newton
// iterations, and two ratios measured in the same run: step time over one evaluation of the Newton
// system (F and J), and step time over one evaluation of the vector field pi grad H compiled the same way.
// Prints one JSON object per line. Usage: pgi_bench_step SCENE [K_MAX | K_MIN:K_MAX] [STEPS] [PREDICTOR_ORDER] [--jit]
// (--jit: the step's maps as native code, StepOptions::jit; its compilation is in build_seconds).
#include "poisson/integrate.hpp"
#include "tools/scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>

namespace {

using Clock = std::chrono::steady_clock;

// Median over 7 repetitions of the time per call of fn (run `calls` times per repetition), in ns.
template <class F>
double median_ns(F&& fn, std::size_t calls) {
    std::vector<double> t;
    for (int rep = 0; rep < 7; ++rep) {
        auto t0 = Clock::now();
        for (std::size_t i = 0; i < calls; ++i) fn(i);
        t.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / double(calls));
    }
    std::nth_element(t.begin(), t.begin() + 3, t.end());
    return t[3];
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: pgi_bench_step SCENE [K_MAX | K_MIN:K_MAX] [STEPS] [PREDICTOR_ORDER] [--jit]\n";
        return 2;
    }
    const pgi::Scene s = pgi::load_scene(argv[1]);
    const std::string ks = argc > 2 ? argv[2] : "6";
    const auto colon = ks.find(':');
    const std::size_t k_min = colon == std::string::npos ? 1 : std::stoul(ks.substr(0, colon));
    const std::size_t k_max = std::stoul(colon == std::string::npos ? ks : ks.substr(colon + 1)), steps = argc > 3 ? std::stoul(argv[3]) : 20000;
    const std::size_t predictor = argc > 4 ? std::stoul(argv[4]) : 0;
    const bool jit = argc > 5 && std::string(argv[5]) == "--jit";
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
    const auto field = pgi::CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), s.phase_space().coordinate_vars());
    Eigen::VectorXd f(x0.size()), y = x0;
    double sink = 0;
    const double field_ns = median_ns([&](std::size_t i) { y[0] = x0[0] + 1e-12 * double(i & 7); field.eval(y.data(), f.data()); sink += f[0]; }, 200000);
    for (std::size_t k = k_min; k <= k_max; ++k) {
        pgi::StepOptions opt;
        opt.k = k;
        opt.dt = s.dt;
        opt.realisation = s.realisation;
        opt.predictor_order = predictor;
        opt.jit = jit;
        auto t0 = Clock::now();
        s.phase_space().ring()->budget().restart();  // each build has the whole time budget
        const pgi::Scheme scheme(s.pi, s.H, s.casimirs, k, s.realisation);  // the scene's problem at order k
        auto st = scheme.stepper(opt, x0);
        const double build_s = std::chrono::duration<double>(Clock::now() - t0).count();
        // the trajectory the step times are taken on, and its mean Newton iterations
        std::vector<Eigen::VectorXd> states;
        Eigen::VectorXd x = x0;
        auto summary = pgi::integrate_steps(st, x, steps, [&](std::size_t, double, const Eigen::VectorXd& z) {
            states.push_back(z);
            return false;
        });
        if (summary.status != pgi::StepStatus::ok) {
            std::cerr << "k = " << k << ": the run failed: " << pgi::to_string(summary.status) << "\n";
            return 3;
        }
        Eigen::VectorXd inc(x0.size());
        const double step_ns = median_ns([&](std::size_t i) { (void)st.step(states[i % states.size()], inc); sink += inc[0]; }, steps);
        const double system_ns = median_ns([&](std::size_t i) { sink += st.newton_system(states[i % states.size()])(0, 0); }, steps);
        std::cout << nlohmann::json{{"scene", s.name}, {"k", k}, {"method_order", st.order()}, {"dt", s.dt},
                                    {"realisation", st.info().method}, {"native_maps", st.info().native_maps}, {"degree", st.info().degree}, {"predictor_order", st.info().predictor_order},
                                    {"ns_per_step", step_ns}, {"newton_iterations_mean", summary.mean_iterations},
                                    {"newton_system_ns", system_ns}, {"vector_field_ns", field_ns},
                                    {"step_over_newton_system", step_ns / system_ns}, {"step_over_vector_field", step_ns / field_ns},
                                    {"build_seconds", build_s}}
                         .dump()
                  << std::endl;
    }
    return sink == 12345.678 ? 1 : 0;  // keeps the timed work observable
}
