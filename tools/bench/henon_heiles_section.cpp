// A Henon-Heiles Poincare section (issue 14's target: energy 1/8, 200 orbits in under 10 s): orbits
// started on the section q1 = 0 with p1 > 0 at energy E, their rising crossings of q1 = 0 located on
// the dense output and written as CSV rows (orbit, t, q2, p2). Prints a JSON summary (wall time, steps,
// crossings, the worst energy error at a crossing, and the time of the same orbits without events) on stdout.
// Usage: pgi_section_henon_heiles SCENE OUT.csv [E = 1/8] [ORBITS = 200] [T = 1000] [SEED = 1]
#include "poisson/events.hpp"
#include "scheme/run_loop.hpp"
#include "scheme/scene.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <random>

int main(int argc, char** argv) try {
    if (argc < 3) {
        std::cerr << "usage: pgi_section_henon_heiles SCENE OUT.csv [E] [ORBITS] [T] [SEED]\n";
        return 2;
    }
    const pgi::Scene s = pgi::load_scene(argv[1]);
    const double E = argc > 3 ? std::stod(argv[3]) : 0.125, T = argc > 5 ? std::stod(argv[5]) : 1000;
    const std::size_t orbits = argc > 4 ? std::stoul(argv[4]) : 200;
    std::mt19937_64 rng(argc > 6 ? std::stoull(argv[6]) : 1);
    // H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3; on q1 = 0 the kinetic energy left for p1
    // is 2E - p2^2 - q2^2 + 2 q2^3/3, which must be positive: draw (q2, p2) uniformly until it is.
    auto p1_squared = [&](double q2, double p2) { return 2 * E - p2 * p2 - q2 * q2 + 2 * q2 * q2 * q2 / 3; };
    std::uniform_real_distribution<double> box(-0.6, 0.7);
    std::vector<Eigen::VectorXd> starts;
    while (starts.size() < orbits) {
        const double q2 = box(rng), p2 = box(rng), k = p1_squared(q2, p2);
        if (k > 0) starts.push_back((Eigen::VectorXd(4) << 0.0, q2, std::sqrt(k), p2).finished());
    }
    const auto t0 = std::chrono::steady_clock::now();
    pgi::StepOptions opt;
    opt.k = s.order;
    opt.dt = s.dt;
    pgi::NewtonStepper stepper = pgi::NewtonStepper::build(s.pi, s.H, opt, starts.front());
    pgi::EventDetector detector(s.scheme->event_set({{"q1", +1, false}}, {}), s.scheme->dense_output(stepper.order()));
    pgi::RunLoop loop(*s.scheme);  // the run of every surface (it watches H at every step, with events or not)
    const auto build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto N = static_cast<std::size_t>(std::ceil(T / s.dt - 1e-9));
    std::size_t steps = 0, crossings = 0, failed = 0;
    double energy_error = 0;
    std::string csv = "orbit,t,q2,p2\n";
    for (std::size_t o = 0; o < orbits; ++o) {
        Eigen::VectorXd x = starts[o];
        const double H0 = pgi::evaluate(s.H, std::vector<double>{x(0), x(1), x(2), x(3), 0, 0, 0, 0});
        const auto run = loop.run(
            stepper, x, N, [](const pgi::RunPoint&) { return false; }, &detector,
            [&](const pgi::Crossing& c) {
                csv += fmt::format("{},{},{},{}\n", o, c.t, c.x(1), c.x(3));
                const double h =
                    0.5 * (c.x(2) * c.x(2) + c.x(3) * c.x(3) + c.x(1) * c.x(1)) - c.x(1) * c.x(1) * c.x(1) / 3;
                energy_error = std::max(energy_error, std::abs(h - H0) / H0);
                return false;
            });
        steps += run.steps;
        crossings += run.crossings;
        if (!run.ok()) ++failed;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // the same orbits without events: what locating the crossings adds to the run
    const auto t1 = std::chrono::steady_clock::now();
    for (std::size_t o = 0; o < orbits; ++o) {
        Eigen::VectorXd x = starts[o];
        (void)loop.run(stepper, x, N, [](const pgi::RunPoint&) { return false; });
    }
    const double plain_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    std::ofstream(argv[2]) << csv;
    std::cout << nlohmann::json{{"energy", E},
                                {"orbits", orbits},
                                {"t_end", T},
                                {"order", s.order},
                                {"method_order", stepper.order()},
                                {"dt", s.dt},
                                {"steps", steps},
                                {"crossings", crossings},
                                {"failed_orbits", failed},
                                {"wall_seconds", seconds},
                                {"build_seconds", build_seconds},
                                {"without_events_seconds", plain_seconds},
                                {"events_cost_ratio", seconds / plain_seconds},
                                {"max_relative_energy_error_at_crossings", energy_error}}
                     .dump()
              << "\n";
    return failed ? 3 : 0;
} catch (const std::exception& e) {
    std::cerr << "pgi_section_henon_heiles: " << e.what() << "\n";
    return 2;
}
