#include "tools/peers/problem.hpp"

#include "tools/commands.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

namespace pgi::peers {

Problem::Problem(const Scene& s, const std::vector<Poly>& watched, PeerRhs peer_rhs,
                 const RhsCompileOptions& rhs_options)
    : scene(s), n(s.phase_space().dim()), watched(watched), num_watched(watched.size()) {
    const std::vector<Poly> vector_field = s.pi.hamiltonian_vector_field(s.H);
    field = CompiledMap::build(vector_field, s.phase_space().coordinate_vars());
    invariants = pgi::invariants(s, watched);
    if (peer_rhs != PeerRhs::none)
        rhs = compile_rhs(vector_field, s.phase_space().coordinate_vars(), s.phase_space().coordinates(), s.name,
                          rhs_options, peer_rhs == PeerRhs::field_and_jacobian);
}

bool needs_jacobian(const std::string& peer) {
    return peer == "rk2imp" || peer == "rk4imp" || peer == "msbdf";
}

const CompiledMap& Problem::jacobian() const {
    std::call_once(jacobian_built_, [this] {
        const auto xs = scene.phase_space().coordinate_vars();
        std::vector<Poly> J;
        for (const auto& fi : scene.pi.hamiltonian_vector_field(scene.H))
            for (std::size_t j = 0; j < n; ++j) J.push_back(derivative(fi, xs[j]));
        jacobian_ = CompiledMap::build(J, xs);
    });
    return jacobian_;
}

Monitor::Monitor(const Problem& p, const double* x0, Samples* s)
    : pr(p), initial(p.invariants.num_outputs()), value(initial), worst(initial.size(), 0.0),
      scale(invariant_scales(p.scene, std::vector<double>(x0, x0 + p.n), p.watched)), samples(s) {
    pr.invariants.eval(x0, initial.data());
}

double Monitor::relative_change(std::size_t i) const {
    return relative_error(value[i], initial[i], scale[i]);
}

void Monitor::operator()(double t, const double* x) {
    if (!pr.monitoring) return;
    pr.invariants.eval(x, value.data());
    for (std::size_t i = 0; i < value.size(); ++i) worst[i] = std::max(worst[i], relative_change(i));
    if (samples && t >= next_sample) {
        const bool has_casimir = value.size() - pr.num_watched > 1;
        samples->push_back({t, relative_change(0), has_casimir ? relative_change(1) : 0.0});
        next_sample = next_sample == 0 ? t * 1.05 + 1e-9 : next_sample * 1.05;  // log-spaced in t
    }
}

double Monitor::casimir_error() const {
    const auto first = worst.begin() + 1, last = worst.end() - static_cast<std::ptrdiff_t>(pr.num_watched);
    return first < last ? *std::max_element(first, last) : 0.0;
}

std::vector<double> Monitor::watched_ratios() const {
    std::vector<double> r;
    for (std::size_t i = value.size() - pr.num_watched; i < value.size(); ++i) r.push_back(value[i] / initial[i]);
    return r;
}

std::string stop_reason(const double* x, std::size_t n, std::size_t steps, double t) {
    constexpr std::size_t step_budget = 50'000'000;
    for (std::size_t i = 0; i < n; ++i)
        if (!std::isfinite(x[i])) return fmt::format("non-finite state at t = {:g}", t);
    if (steps > step_budget) return fmt::format("more than {} steps by t = {:g}", step_budget, t);
    return {};
}

Outcome finish(State x, std::size_t steps, Clock::time_point start, const Monitor& monitor, std::string failure) {
    Outcome o;
    o.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    o.x = std::move(x);
    o.steps = steps;
    o.evaluations = monitor.pr.evaluations;
    o.energy_error = monitor.energy_error();
    o.casimir_error = monitor.casimir_error();
    o.watched = monitor.watched_ratios();
    const bool finite = std::all_of(o.x.begin(), o.x.end(), [](double v) { return std::isfinite(v); });
    o.failure = failure.empty() && !finite ? "non-finite state" : std::move(failure);
    o.ok = o.failure.empty();
    return o;
}

Outcome best_of(const Method& m, const Problem& pr, const State& x0, double T, double value, int repeats) {
    const PreparedRun run =
        m.prepare ? m.prepare(pr, x0, value)
                  : PreparedRun([&](const State& x, double t, Samples* s) { return m.run(pr, x, t, value, s); });
    // the monitor is on for the outcome's run and off for the timed ones, and on again however this ends
    struct Monitoring {
        const Problem& pr;
        ~Monitoring() { pr.monitoring = true; }
    } restore{pr};
    pr.monitoring = true;
    Outcome best = run(x0, T, nullptr);
    if (!best.ok) return best;
    pr.monitoring = false;
    double fastest = std::numeric_limits<double>::infinity(), total = 0;
    for (int r = 0; r < std::max(repeats, 1) && (r == 0 || total < 0.3); ++r) {
        const Outcome o = run(x0, T, nullptr);
        if (!o.ok || o.x != best.x)
            throw std::logic_error(fmt::format("{} at {:g}: a repeated run ended {}", m.name, value,
                                               o.ok ? "at another state" : "in failure: " + o.failure));
        if (o.seconds < fastest) fastest = o.seconds, best.native_maps = o.native_maps;
        total += o.seconds;
    }
    best.seconds = fastest;
    return best;
}

double absolute_tolerance(double tol, const State& x0) {
    double scale = 0;
    for (double v : x0) scale = std::max(scale, std::abs(v));
    return tol * (scale > 0 ? scale : 1.0);
}

double distance(const State& a, const State& b) {
    double d = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
    return d;
}

}  // namespace pgi::peers
