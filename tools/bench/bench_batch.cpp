// Throughput of CompiledMap::eval_batch (m points at once, structure of arrays) against m calls of eval()
// (one point at a time), per point, on maps a step evaluates: the vector field pi grad H over x, and the
// radial realisation alpha through p-degree 6 over (x, p). Prints one JSON object per line with the ratio
// single / batch (above 1: the batch is faster). Usage: pgi_bench_batch SCENE...
#include "scheme/scheme.hpp"
#include "scheme/scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <random>

namespace {

using Clock = std::chrono::steady_clock;

// The median over 7 repetitions of the time of fn() per point (fn evaluates `points` points), in ns;
// each repetition lasts about 20 ms.
template <class F>
double median_ns_per_point(F&& fn, std::size_t points) {
    std::size_t calls = 1;
    for (auto t0 = Clock::now(); Clock::now() - t0 < std::chrono::milliseconds(20); ++calls) fn();
    std::vector<double> t;
    for (int rep = 0; rep < 7; ++rep) {
        const auto t0 = Clock::now();
        for (std::size_t i = 0; i < calls; ++i) fn();
        t.push_back(std::chrono::duration<double, std::nano>(Clock::now() - t0).count() / double(calls * points));
    }
    std::nth_element(t.begin(), t.begin() + 3, t.end());
    return t[3];
}

void measure(const std::string& scene, const std::string& name, const pgi::CompiledMap& map,
             const std::vector<double>& center) {
    const std::size_t k = map.num_inputs(), O = map.num_outputs();
    std::mt19937 gen(1);
    std::uniform_real_distribution<double> jitter(0.9, 1.1);
    for (std::size_t m : {1, 4, 8, 16, 64, 256, 1024}) {
        std::vector<double> soa(k * m), aos(k * m), out(O * m), scratch;
        for (std::size_t j = 0; j < m; ++j)
            for (std::size_t v = 0; v < k; ++v)
                soa[v * m + j] = aos[j * k + v] = center[v] * jitter(gen) + 0.01 * jitter(gen);
        double sink = 0;
        const double single = median_ns_per_point(
            [&] {
                for (std::size_t j = 0; j < m; ++j) map.eval(aos.data() + j * k, out.data() + j * O);
                sink += out[0];
            },
            m);
        const double batch = median_ns_per_point(
            [&] {
                map.eval_batch(soa.data(), out.data(), m, scratch);
                sink += out[0];
            },
            m);
        std::cout << nlohmann::json{{"scene", scene},
                                    {"map", name},
                                    {"inputs", k},
                                    {"outputs", O},
                                    {"monomials", map.num_monomials()},
                                    {"terms", map.num_terms()},
                                    {"m", m},
                                    {"single_ns_per_point", single},
                                    {"batch_ns_per_point", batch},
                                    {"single_over_batch", single / batch},
                                    {"sink", sink != 0}}
                         .dump()
                  << std::endl;
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::cerr << "usage: pgi_bench_batch SCENE...\n";
        return 2;
    }
    for (int a = 1; a < argc; ++a) {
        const pgi::Scene s = pgi::load_scene(argv[a]);
        const pgi::PhaseSpace& M = s.phase_space();
        const std::vector<double> x0 = *s.x0;
        measure(s.name, "vector field",
                pgi::CompiledMap::build(s.pi.hamiltonian_vector_field(s.H), M.coordinate_vars()), x0);
        const pgi::Scheme radial(s.pi, s.H, {}, 2, pgi::RealisationChoice::radial);
        std::vector<pgi::Poly> alpha;
        for (const auto& a_i : radial.realisation(6).alpha) alpha.push_back(a_i.sum());
        std::vector<std::size_t> xp;
        for (std::size_t i = 0; i < 2 * M.dim(); ++i) xp.push_back(i);
        std::vector<double> center = x0;
        center.resize(2 * M.dim(), 0.05);  // momenta of the size grad S_dt has at dt ~ 0.1
        measure(s.name, "radial alpha, p-degree 6", pgi::CompiledMap::build(alpha, xp), center);
    }
    return 0;
}
