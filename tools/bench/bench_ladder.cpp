// A dt ladder as a user's work-precision sweep walks it through the C++ API: one Scheme of the scene at order K, then
// scheme.stepper(dt, x0) per point (its build timed apart: the exact phase at the first point, a few milliseconds
// after), and the best of 20 runs to T stepping only. Prints one JSON object per point: dt, build_seconds, ns_per_step,
// native_maps, predictor_order, hessian_terms and mean Newton iterations. The native code policy as asked: with an
// empty $PGI_JIT_CACHE, `always` shows what a first --jit build compiles at each point (only the maps that changed
// since the last) and a second run with the same cache what every later run attaches.
// Usage: pgi_bench_ladder SCENE K [down|up] [automatic|always|never] [T]   (the ladder: 5, 4, 3, 2 and 1.6 times the
// scene's dt, walked down or up)
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: pgi_bench_ladder SCENE K [down|up] [automatic|always|never] [T]\n";
        return 2;
    }
    using Clock = std::chrono::steady_clock;
    const pgi::Scene s = pgi::load_scene(argv[1]);
    const std::size_t k = std::stoul(argv[2]);
    const bool down = argc <= 3 || std::string(argv[3]) != "up";
    const std::string policy = argc > 4 ? argv[4] : "automatic";
    const double T = argc > 5 ? std::stod(argv[5]) : 100.0;
    const pgi::NativePolicy jit = policy == "always"  ? pgi::NativePolicy::always
                                  : policy == "never" ? pgi::NativePolicy::never
                                                      : pgi::NativePolicy::automatic;
    const pgi::Scheme scheme(s.pi, s.H, s.casimirs, k, s.realisation, false, jit, s.parameters);
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
    std::vector<double> ladder;
    for (const double f : {5.0, 4.0, 3.0, 2.0, 1.6}) ladder.push_back(f * s.dt);
    if (!down) std::reverse(ladder.begin(), ladder.end());
    for (const double dt : ladder) {
        const auto built = Clock::now();
        pgi::NewtonStepper st = scheme.stepper(dt, x0);
        const double build_seconds = std::chrono::duration<double>(Clock::now() - built).count();
        const auto steps = static_cast<long>(std::llround(T / dt));
        double best = INFINITY;
        long iterations = 0;
        Eigen::VectorXd x(x0.size()), inc(x0.size());
        for (int rep = 0; rep < 20; ++rep) {
            x = x0, iterations = 0;
            const auto start = Clock::now();
            for (long i = 0; i < steps; ++i) {
                if (st.step(x, dt, inc) != pgi::StepStatus::ok) {
                    std::cerr << "step " << i << " failed at dt " << dt << "\n";
                    return 1;
                }
                x += inc, iterations += st.last_iterations();
            }
            best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
        }
        std::cout << nlohmann::json{{"scene", s.name},
                                    {"k", k},
                                    {"dt", dt},
                                    {"policy", policy},
                                    {"build_seconds", build_seconds},
                                    {"ns_per_step", best / double(steps) * 1e9},
                                    {"native_maps", st.native_maps()},
                                    {"predictor_order", st.info().predictor_order},
                                    {"hessian_terms", st.info().hessian_terms},
                                    {"newton_iterations_mean", double(iterations) / double(steps)}}
                         .dump()
                  << "\n";
    }
}
