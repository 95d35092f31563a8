// The step alone, one state at a time against the batch (BatchStepper, batches of 16) on each instruction set
// the processor has: m states from the scene's x0 scaled by 0.5..1.5, each stepped `steps` times at the scene's
// dt, the same states both ways (and the same final states, checked bit for bit). Prints one JSON line per
// instruction set with ns per step and the ratio single / batch (above 1: the batch is faster per state).
// Usage: pgi_bench_batch_step SCENE [m = 1024] [steps = 1000]
#include "poisson/batch_step.hpp"
#include "scheme/scheme.hpp"
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <iostream>

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// X[v m + j] stepped in place one state at a time; the seconds it took.
double step_one_by_one(pgi::NewtonStepper stepper, std::vector<double>& X, std::size_t m, std::size_t n,
                       std::size_t steps, double dt) {
    Eigen::VectorXd x(static_cast<Eigen::Index>(n)), increment(static_cast<Eigen::Index>(n));
    const auto t0 = Clock::now();
    for (std::size_t j = 0; j < m; ++j) {
        for (std::size_t v = 0; v < n; ++v) x[Eigen::Index(v)] = X[v * m + j];
        for (std::size_t k = 0; k < steps && stepper.step(x, dt, increment) == pgi::StepStatus::ok; ++k) x += increment;
        for (std::size_t v = 0; v < n; ++v) X[v * m + j] = x[Eigen::Index(v)];
    }
    return seconds_since(t0);
}

// The same in batches of `lanes` (each lane's state advanced while its steps are ok).
double step_in_batches(pgi::BatchStepper& batch, std::vector<double>& X, std::size_t m, std::size_t n,
                       std::size_t steps, double dt) {
    const std::size_t L = batch.lanes();
    std::vector<double> B(n * L), increments(n * L);
    std::vector<pgi::StepStatus> status(L);
    const auto t0 = Clock::now();
    for (std::size_t j = 0; j < m; j += L) {
        const std::size_t c = std::min(L, m - j);
        for (std::size_t v = 0; v < n; ++v)
            for (std::size_t l = 0; l < c; ++l) B[v * c + l] = X[v * m + j + l];
        std::vector<bool> going(c, true);
        for (std::size_t k = 0; k < steps; ++k) {
            batch.step(B.data(), c, dt, increments.data(), status.data());
            for (std::size_t l = 0; l < c; ++l) {
                going[l] = going[l] && status[l] == pgi::StepStatus::ok;
                if (going[l])
                    for (std::size_t v = 0; v < n; ++v) B[v * c + l] += increments[v * c + l];
            }
        }
        for (std::size_t v = 0; v < n; ++v)
            for (std::size_t l = 0; l < c; ++l) X[v * m + j + l] = B[v * c + l];
    }
    return seconds_since(t0);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: pgi_bench_batch_step SCENE [m] [steps]\n";
        return 2;
    }
    const pgi::Scene s = pgi::load_scene(argv[1]);
    const std::size_t m = argc > 2 ? std::stoul(argv[2]) : 1024, steps = argc > 3 ? std::stoul(argv[3]) : 1000;
    const std::size_t n = s.phase_space().dim();
    const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(n));
    const pgi::NewtonStepper stepper = s.scheme->stepper(s.dt, x0);
    std::vector<double> X0(n * m);
    for (std::size_t j = 0; j < m; ++j)
        for (std::size_t v = 0; v < n; ++v) X0[v * m + j] = x0[Eigen::Index(v)] * (0.5 + double(j) / double(m));
    std::vector<pgi::LaneInstructions> sets{pgi::LaneInstructions::sse2};
    if (pgi::processor_has_avx2()) sets.push_back(pgi::LaneInstructions::avx2);
    for (const auto instructions : sets) {
        std::vector<double> single = X0, batched = X0;
        pgi::BatchStepper batch(stepper, 16, instructions);
        const double t_single = step_one_by_one(stepper, single, m, n, steps, s.dt);
        const double t_batch = step_in_batches(batch, batched, m, n, steps, s.dt);
        const double per = 1e9 / double(m * steps);
        const char* name = batch.instructions() == pgi::LaneInstructions::avx2 ? "avx2"
                           : batch.instructions() == pgi::LaneInstructions::sse2
                               ? "sse2"
                               : "no lane form (state by state after a batched predictor)";
        std::cout << nlohmann::json{{"scene", s.name},
                                    {"k", s.scheme->order()},
                                    {"m", m},
                                    {"steps", steps},
                                    {"lanes", name},
                                    {"single_ns_per_step", t_single * per},
                                    {"batch_ns_per_step", t_batch * per},
                                    {"single_over_batch", t_single / t_batch},
                                    {"same_bits", single == batched}}
                         .dump()
                  << std::endl;
    }
    return 0;
}
