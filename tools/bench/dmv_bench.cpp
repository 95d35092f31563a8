// dmv_bench: the free rigid body, pgi at k = 10..16 against the discrete Moser-Veselov peer (tools/bench/dmv.*:
// plain DMV of order 2 and Hairer-Vilmart's preprocessed DMV of orders 4..10) and GSL's rk8pd, on a step
// (tolerance) ladder to T = 100, stepping only, errors against tools/peers' long double Fehlberg 7(8)
// reference; the time to final error 1e-11 (log-log interpolation between the two runs bracketing it, or
// the cheapest run reaching it); pgi's is the best over its orders (a user picks the order, as the DMV order).
// Prints JSON on stdout (read by tools/bench/bench_speed.py).
//
//   dmv_bench SCENE [--target 1e-11] [--t-end 100]
//
// The scene must be the free rigid body m' = m x (I^-1 m) (checked: its field is compared with that
// formula at a few points, with I read off H(e_i) = 1 / (2 I_i)); exit 2 otherwise.
#include "tools/bench/dmv.hpp"
#include "tools/peers/methods.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>

namespace {

using namespace pgi::peers;
using nlohmann::json;
using pgi::bench::Dmv;
using pgi::bench::Vec3;

// I_i from H(e_i) = 1 / (2 I_i), then the scene's field checked against m x (I^-1 m) at a few points.
Vec3 rigid_body_inertia(const Problem& pr) {
    if (pr.n != 3) throw std::invalid_argument("dmv_bench: the scene must have 3 coordinates (the free rigid body)");
    Vec3 I{};
    std::vector<double> inv(pr.invariants.num_outputs());
    for (int i = 0; i < 3; ++i) {
        double e[3] = {0, 0, 0};
        e[i] = 1;
        pr.invariants.eval(e, inv.data());
        if (!(inv[0] > 0)) throw std::invalid_argument("dmv_bench: H(e_i) must be positive (H = sum m_i^2 / (2 I_i))");
        I[i] = 1 / (2 * inv[0]);
    }
    for (const Vec3& m : {Vec3{0.3, -0.7, 1.1}, Vec3{-1.3, 0.2, 0.5}}) {
        double f[3];
        pr.field.eval(m.data(), f);
        const Vec3 w{m[0] / I[0], m[1] / I[1], m[2] / I[2]};
        const Vec3 g{m[1] * w[2] - m[2] * w[1], m[2] * w[0] - m[0] * w[2], m[0] * w[1] - m[1] * w[0]};
        for (int i = 0; i < 3; ++i)
            if (std::abs(f[i] - g[i]) > 1e-12 * (1 + std::abs(g[i])))
                throw std::invalid_argument(
                    "dmv_bench: the scene's field is not m x (I^-1 m) with I read from H: not the free rigid body");
    }
    return I;
}

Method dmv_method(int order, const Vec3& I) {
    return {fmt::format("dmv{}", order), true,
            [order, I](const Problem& pr, const State& x0, double T, double h, Samples* samples) {
                const Dmv dmv(order, I);
                Vec3 m{x0[0], x0[1], x0[2]};
                pr.evaluations = 0;
                Monitor monitor(pr, x0.data(), samples);
                const auto N = static_cast<std::size_t>(std::llround(T / h));
                std::size_t steps = 0;
                std::string failure;
                const auto start = Clock::now();
                try {
                    for (; steps < N; ++steps) {
                        dmv.step(m, h);
                        monitor(double(steps + 1) * h, m.data());
                    }
                } catch (const std::runtime_error& e) {
                    failure = fmt::format("{} at step {}", e.what(), steps + 1);
                }
                return finish(State(m.begin(), m.end()), steps, start, monitor, failure);
            }};
}

struct Point {
    double error, seconds;
    std::size_t steps;
};

// Time to the target error along the ladder, runs ordered by step count (cost): log-log interpolation
// between the first two consecutive runs whose errors straddle the target, else the cheapest run reaching
// it. ns per step is that of the runs used (the cheaper one's, where one run is used).
json at_target(const std::string& name, std::vector<Point> pts, double target) {
    std::sort(pts.begin(), pts.end(), [](const Point& a, const Point& b) { return a.steps < b.steps; });
    auto ns = [](const Point& p) { return 1e9 * p.seconds / double(std::max<std::size_t>(p.steps, 1)); };
    json out{
        {"method", name}, {"ns_per_step", nullptr}, {"seconds", nullptr}, {"how", "not reached"}, {"steps", nullptr}};
    if (!pts.empty() && pts[0].error <= target)
        return out.update({{"seconds", pts[0].seconds},
                           {"how", "cheapest reaching"},
                           {"steps", pts[0].steps},
                           {"ns_per_step", ns(pts[0])}}),
               out;
    for (std::size_t i = 0; i + 1 < pts.size(); ++i)
        if (pts[i].error > target && target >= pts[i + 1].error) {
            const double w = std::log(target / pts[i].error) / std::log(pts[i + 1].error / pts[i].error);
            out["seconds"] = std::exp(std::log(pts[i].seconds) + w * std::log(pts[i + 1].seconds / pts[i].seconds));
            out["how"] = "interpolated";
            out["steps"] = std::llround(std::exp(std::log(double(pts[i].steps)) +
                                                 w * std::log(double(pts[i + 1].steps) / double(pts[i].steps))));
            out["ns_per_step"] = 0.5 * (ns(pts[i]) + ns(pts[i + 1]));
            return out;
        }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"dmv_bench: the rigid body, pgi k = 10..16 against discrete Moser-Veselov (orders 2..10) and rk8pd"};
    std::string scene_file;
    double target = 1e-11, T = 100;
    app.add_option("scene", scene_file)->required();
    app.add_option("--target", target, "the final error the times are compared at (default 1e-11)");
    app.add_option("--t-end", T, "final time (default 100)");
    CLI11_PARSE(app, argc, argv);
    try {
        if (!(target > 0) || !(T > 0)) throw std::invalid_argument("--target and --t-end must be positive");
        const pgi::Scene scene = pgi::load_scene(scene_file, {});
        pgi::require_valid(scene);
        if (!scene.x0) throw std::invalid_argument(scene_file + ": [run] x0 is needed");
        const Problem pr(scene, {});
        const Vec3 I = rigid_body_inertia(pr);
        const State x0 = *scene.x0;
        const State ref = reference_solution(pr, x0, T, 1e-18L);
        const double ref_accuracy = std::max(distance(ref, reference_solution(pr, x0, T, 1e-17L)), 1e-17);
        const std::vector<std::size_t> pgi_orders{10, 12, 14, 16};
        std::vector<Method> methods;
        for (std::size_t k : pgi_orders) methods.push_back(pgi_method(k));
        for (std::size_t k : pgi_orders) methods.push_back(pgi_method(k, std::nullopt, true));  // native code (--jit)
        for (int p : {10, 8, 6, 4, 2}) methods.push_back(dmv_method(p, I));
        for (auto& m : gsl_methods())
            if (m.name == "rk8pd") methods.push_back(std::move(m));
        std::vector<double> steps, tols;
        for (int j = 0; j < 9; ++j) steps.push_back(0.8 / std::pow(2.0, j));
        for (int e = 6; e <= 16; ++e) tols.push_back(std::pow(10.0, -e));
        json rows = json::array(), targets = json::array();
        for (const auto& m : methods) {
            std::vector<Point> pts;
            for (double v : m.fixed_step ? steps : tols) {
                const Outcome o = best_of(m, pr, x0, T, v);
                const double err = o.ok ? distance(o.x, ref) : std::nan("");
                const bool usable = o.ok && err >= 100 * ref_accuracy;
                std::cerr << fmt::format("{:8s} {}={:<10g} error {:9.2e}  {:9.5f} s  {:8d} steps{}\n", m.name,
                                         m.fixed_step ? "dt" : "tol", v, err, o.seconds, o.steps,
                                         o.ok ? "" : "  FAILED: " + o.failure);
                rows.push_back({{"method", m.name},
                                {m.fixed_step ? "dt" : "tol", v},
                                {"error", o.ok ? json(err) : json()},
                                {"seconds", o.seconds},
                                {"steps", o.steps},
                                {"setup_seconds", o.setup_seconds},
                                {"usable", usable},
                                {"failure", o.failure}});
                if (usable) pts.push_back({err, o.seconds, o.steps});
            }
            targets.push_back(at_target(m.name, pts, target));
        }
        auto seconds_of = [&](const std::string& name) {
            for (const auto& t : targets)
                if (t["method"] == name && !t["seconds"].is_null()) return t["seconds"].get<double>();
            return std::nan("");
        };
        // pgi's best order, interpreted and with native code
        const auto best = [&](const std::string& suffix) {
            std::string b;
            for (std::size_t k : pgi_orders) {
                const std::string name = fmt::format("pgi-k{}{}", k, suffix);
                if (std::isfinite(seconds_of(name)) && (b.empty() || seconds_of(name) < seconds_of(b))) b = name;
            }
            return b;
        };
        const std::string pgi_best = best(""), pgi_best_jit = best("-jit");
        const double ratio = pgi_best.empty() ? std::nan("") : seconds_of("dmv10") / seconds_of(pgi_best);
        const double ratio_jit = pgi_best_jit.empty() ? std::nan("") : seconds_of("dmv10") / seconds_of(pgi_best_jit);
        json out{{"scene", scene.name},
                 {"t_end", T},
                 {"target", target},
                 {"inertia", I},
                 {"reference", {{"method", "Fehlberg 7(8), long double, tol 1e-18"}, {"accuracy", ref_accuracy}}},
                 {"at_target", targets},
                 {"pgi_best", pgi_best},
                 {"ratio", std::isfinite(ratio) ? json(ratio) : json()},
                 {"pgi_best_jit", pgi_best_jit},
                 {"ratio_jit", std::isfinite(ratio_jit) ? json(ratio_jit) : json()},
                 {"rows", rows}};
        std::cout << out.dump(1) << "\n";
    } catch (const pgi::SceneError& e) {
        std::cerr << "dmv_bench: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "dmv_bench: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
