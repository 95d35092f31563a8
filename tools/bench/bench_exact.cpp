// Times pgi's exact phase on the workloads of tools/bench/bench_exact.py and bench_modified.py, prints JSON:
// {"seconds": median wall time, "repetitions": R, "allocator": what the program allocates with
// (tools/program_allocator), "result": [polynomials]} for one workload.
#include "scheme/scheme.hpp"
#include "scheme/scene.hpp"
#include "tools/program_allocator.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iostream>

namespace {

using Clock = std::chrono::steady_clock;

std::vector<std::string> strings(const std::vector<pgi::Poly>& v) {
    std::vector<std::string> out;
    for (const auto& p : v) out.push_back(p.to_string());
    return out;
}

// workload(scene) -> polynomials, timed from the loaded scene on (parsing excluded, as in the sympy versions),
// each repetition by a new Scheme: what a user's first request costs.
std::vector<pgi::Poly> run(const std::string& kind, const pgi::Scene& s, std::size_t n, std::size_t k) {
    if (kind == "modified") return pgi::Scheme(s.pi, s.H, {}, k, s.realisation).modified_hamiltonian(n);
    if (kind == "terms") return pgi::Scheme(s.pi, s.H, {}, n, s.realisation).terms();
    auto r = pgi::Scheme(s.pi, s.H, {}, 1, pgi::RealisationChoice::radial).realisation(n);
    std::vector<pgi::Poly> alpha;
    for (const auto& a : r.alpha) alpha.push_back(a.sum());
    return alpha;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4 && argc != 5) {
        std::cerr << "usage: pgi_bench_exact SCENE terms|radial|modified N [K]\n";
        return 2;
    }
    pgi::Scene scene = pgi::load_scene(argv[1]);
    const std::string kind = argv[2];
    const std::size_t n = std::stoul(argv[3]), k = argc == 5 ? std::stoul(argv[4]) : 0;
    std::vector<double> times;
    std::vector<pgi::Poly> result;
    const auto start = Clock::now();
    while (times.size() < 5 || (Clock::now() - start < std::chrono::seconds(1) && times.size() < 1000)) {
        auto t0 = Clock::now();
        scene.phase_space().ring()->budget().restart();  // each repetition has the whole time budget
        result = run(kind, scene, n, k);
        times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
    std::cout << nlohmann::json{{"seconds", times[times.size() / 2]},
                                {"repetitions", times.size()},
                                {"allocator", pgi::program_allocator()},
                                {"result", strings(result)}}
                     .dump()
              << "\n";
}
