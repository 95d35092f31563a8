// pgi modified --splitting and the report's splitting section: the modified Hamiltonian of a splitting
// method for the scene's H = A + B, exact, and (when the flows of A and B are polynomial) a run of the
// splitting that measures how well its orbit keeps the truncated series.
#include "tools/commands.hpp"

#include "magnus/polynomial_flow.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pgi {

using nlohmann::json;

namespace {

// H and sum_j dt^j sum_c w^c H[j][c], compiled: outputs 1 + j d + c
class Watched {
public:
    Watched(const Scene& scene, const SplittingModified& Ht) : d_(Ht.H.front().size()) {
        std::vector<Poly> f{scene.H};
        for (const auto& Hj : Ht.H) f.insert(f.end(), Hj.begin(), Hj.end());
        map_ = CompiledMap::build(f, scene.phase_space().coordinate_vars());
        out_.resize(map_.num_outputs());
    }
    // {H(x), Htilde(x)} at step dt
    std::pair<double, double> operator()(const std::vector<double>& x, double dt) {
        map_.eval(x.data(), out_.data());
        const double w = yoshida_weight();
        double sum = 0, dtj = 1;
        for (std::size_t j = 0; 1 + j * d_ < out_.size(); ++j, dtj *= dt) {
            double wc = 1;
            for (std::size_t c = 0; c < d_; ++c, wc *= w) sum += dtj * wc * out_[1 + j * d_ + c];
        }
        return {out_[0], sum};
    }

private:
    std::size_t d_;
    CompiledMap map_;
    std::vector<double> out_;
};

// the largest changes of H and of Htilde (through dt^m) along the splitting's orbit from x0 to t_end
std::pair<double, double> splitting_drifts(const Scene& scene, const SplittingModified& Ht, const PolynomialFlow& A,
                                           const PolynomialFlow& B, double dt, std::size_t steps) {
    Watched watched(scene, Ht);
    std::vector<double> x = *scene.x0;
    const auto [e0, m0] = watched(x, dt);
    const double scale = term_size(scene.H, x);  // Htilde = H + O(dt^p): both measured against H's terms at x0
    double worst_H = 0, worst_m = 0;
    for (std::size_t n = 1; n <= steps; ++n) {
        splitting_step(Ht.method, A, B, dt, x);
        const auto [e, m] = watched(x, dt);
        if (!std::isfinite(e) || !std::isfinite(m))
            throw NumericalFailure(fmt::format("{} splitting: non-finite state at step {} (t = {:.17g})",
                                               to_string(Ht.method), n, double(n) * dt));
        worst_H = std::max(worst_H, relative_error(e, e0, scale));
        worst_m = std::max(worst_m, relative_error(m, m0, scale));
    }
    return {worst_H, worst_m};
}

// the first power of dt above m whose term can be non-zero: symmetric methods have even powers only, and
// Yoshida's composition none below dt^4
std::size_t expected_order(SplittingMethod method, std::size_t m) {
    if (method == SplittingMethod::lie_trotter) return m + 1;
    const std::size_t even = (m + 1) % 2 == 0 ? m + 1 : m + 2;
    return method == SplittingMethod::yoshida ? std::max<std::size_t>(even, 4) : even;
}

}  // namespace

json splitting_report(const Scene& scene, SplittingMethod method, std::size_t m,
                      const std::function<json(const Poly&)>& entry) {
    if (!scene.splitting_A)
        throw SceneError(scene.file, "splitting.A", "missing: give [splitting] A = \"part of H\" (B = H - A)");
    const Poly& A = *scene.splitting_A;
    const Poly B = scene.H - A;
    const auto Ht = splitting_modified_hamiltonian(scene.pi, A, B, method, m);
    json terms = json::array();
    for (const auto& Hj : Ht.H) {
        json c = json::array();
        for (const auto& P : Hj) c.push_back(entry ? entry(P) : json(P.to_string()));
        terms.push_back(c);
    }
    json r{{"coordinates", scene.phase_space().coordinates()},
           {"splitting", to_string(method)},
           {"method_order", method_order(method)},
           {"A", A.to_string()},
           {"B", B.to_string()},
           {"modified", terms},
           {"basis", method == SplittingMethod::yoshida ? json{"1", "w", "w^2"} : json{"1"}}};
    if (method == SplittingMethod::yoshida) r["w"] = "1/(2 - 2^(1/3))";
    auto fa = PolynomialFlow::build(scene.pi, A), fb = PolynomialFlow::build(scene.pi, B);
    if (!fa || !fb) {
        r["run"] = {
            {"skipped", fmt::format("the flow of {} is not polynomial in t (its vector field is not nilpotent): "
                                    "the series is exact, but pgi cannot run the splitting to check it",
                                    fa ? "B" : "A")}};
        return r;
    }
    if (!scene.x0 || !scene.t_end) {
        r["run"] = {{"skipped", "the scene has no [run] x0 and t_end"}};
        return r;
    }
    // the same interval at dt and at dt/2: the ratio of the drifts measures the order of conservation
    const auto N = static_cast<std::size_t>(std::ceil(*scene.t_end / scene.dt - 1e-9));
    const auto [h1, m1] = splitting_drifts(scene, Ht, *fa, *fb, scene.dt, N);
    const auto [h2, m2] = splitting_drifts(scene, Ht, *fa, *fb, scene.dt / 2, 2 * N);
    r["run"] = {{"dt", scene.dt},
                {"steps", N},
                {"t", double(N) * scene.dt},
                {"energy_error_max", h1},
                {"modified_energy_error_max", m1},
                {"energy_error_max_half_dt", h2},
                {"modified_energy_error_max_half_dt", m2},
                {"energy_order_measured", std::log2(h1 / h2)},
                {"modified_order_measured", std::log2(m1 / m2)},
                {"modified_order_expected", expected_order(method, m)}};
    return r;
}

std::string splitting_text(const json& r) {
    const bool yoshida = r["basis"].size() > 1;
    std::string out =
        fmt::format("modified Hamiltonian of the {} splitting (method order {}) of H = A + B,\n  A = {}\n  B = {}\n",
                    r["splitting"].get<std::string>(), r["method_order"].get<std::size_t>(), r["A"].get<std::string>(),
                    r["B"].get<std::string>());
    out += "Htilde = sum_j dt^j H_j";
    out += yoshida ? ", H_j = P_j0 + w P_j1 + w^2 P_j2 with w = 1/(2 - 2^(1/3)):\n" : ":\n";
    for (std::size_t j = 0; j < r["modified"].size(); ++j) {
        const auto& c = r["modified"][j];
        const bool zero = std::all_of(c.begin(), c.end(), [](const json& p) { return p.get<std::string>() == "0"; });
        if (!yoshida || zero)
            out += fmt::format("H_{} = {}\n", j, c[0].get<std::string>());
        else
            for (std::size_t k = 0; k < c.size(); ++k)
                out += fmt::format("P_{}{} = {}\n", j, k, c[k].get<std::string>());
    }
    const json& run = r["run"];
    if (run.contains("skipped"))
        out += fmt::format("no numerical check: {}\n", run["skipped"].get<std::string>());
    else
        out += fmt::format(
            "run of {} steps of dt = {} to t = {} with exact flows of A and B: max relative error of H {:.3e} "
            "(order {:.2f} measured at dt/2), of Htilde through dt^{} {:.3e} (order {:.2f}, expected {})\n",
            run["steps"].get<std::size_t>(), run["dt"].get<double>(), run["t"].get<double>(),
            run["energy_error_max"].get<double>(), run["energy_order_measured"].get<double>(), r["modified"].size() - 1,
            run["modified_energy_error_max"].get<double>(), run["modified_order_measured"].get<double>(),
            run["modified_order_expected"].get<std::size_t>());
    return out;
}

}  // namespace pgi
