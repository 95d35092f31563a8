#include "tools/commands.hpp"

#include "magnus/magnus.hpp"
#include "magnus/modified_hamiltonian.hpp"
#include "poisson/hamilton_jacobi.hpp"

#include <fmt/format.h>

namespace pgi {

using nlohmann::json;

namespace {

json strings(const std::vector<Poly>& v) {
    json a = json::array();
    for (const auto& p : v) a.push_back(p.to_string());
    return a;
}

std::vector<Poly> sums(const std::vector<Series>& v) {
    std::vector<Poly> out;
    for (const auto& s : v) out.push_back(s.sum());
    return out;
}

std::vector<std::string> momenta_names(const PhaseSpace& M) {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < M.dim(); ++i) out.push_back(M.ring()->names()[M.p(i)]);
    return out;
}

}  // namespace

json check_report(const Scene& scene) {
    const PhaseSpace& M = scene.phase_space();
    const auto& names = M.coordinates();
    json r{{"scene", scene.name}, {"file", scene.file.string()}, {"coordinates", names},
           {"class", to_string(scene.pi.structure_class())}, {"skew", true}};
    bool ok = true;
    json jacobi{{"holds", true}};
    if (auto f = scene.pi.jacobi_failure()) {
        jacobi = {{"holds", false}, {"triple", {names[f->i], names[f->j], names[f->k]}}, {"jacobiator", f->jacobiator.to_string()}};
        ok = false;
    }
    r["jacobi"] = jacobi;
    r["casimirs"] = json::array();
    for (const auto& C : scene.casimirs) {
        json c{{"C", C.to_string()}, {"holds", true}};
        if (auto f = scene.pi.casimir_failure(C)) {
            c = {{"C", C.to_string()}, {"holds", false}, {"component", names[f->component]}, {"value", f->value.to_string()}};
            ok = false;
        }
        r["casimirs"].push_back(c);
    }
    if (jacobi["holds"]) {
        // S_k reads alpha through degree k - 1; the identities in degrees < k need alpha through degree k.
        Realisation real = build_realisation(scene.pi, scene.realisation, scene.order);
        json id{{"method", real.method}, {"checked_below_degree", real.degree}, {"holds", true}};
        if (auto d = realisation_defect(scene.pi, real)) {
            id["holds"] = false;
            id["failure"] = {{"identity", d->identity}, {"i", names[d->i]}, {"j", names[d->j]}, {"degree", d->degree},
                             {"defect", d->defect.to_string()}};
            ok = false;
        }
        r["realisation"] = id;
    }
    r["ok"] = ok;
    return r;
}

json terms_report(const Scene& scene) {
    const std::size_t D = realisation_degree_for_order(scene.order);
    Realisation real = build_realisation(scene.pi, scene.realisation, D);
    auto S = hamilton_jacobi_terms(scene.phase_space(), real, scene.H, scene.order);
    return {{"coordinates", scene.phase_space().coordinates()}, {"class", to_string(scene.pi.structure_class())},
            {"realisation", real.method}, {"order", scene.order}, {"S", strings(S)}};
}

json realisation_report(const Scene& scene, std::size_t D) {
    Realisation real = build_realisation(scene.pi, scene.realisation, D);
    const PhaseSpace& M = scene.phase_space();
    return {{"coordinates", M.coordinates()}, {"momenta", momenta_names(M)},
            {"class", to_string(scene.pi.structure_class())}, {"realisation", real.method}, {"degree", D},
            {"alpha", strings(sums(real.alpha))}, {"beta", strings(sums(real.beta))}};
}

json magnus_report(const Scene& scene, std::size_t m) {
    if (!scene.magnus_h) throw SceneError(scene.file, "magnus.h", "missing: the scene has no [magnus] h");
    Series M = magnus_series(scene.pi, *scene.magnus_h, m);
    std::vector<Poly> terms;
    for (std::size_t j = 0; j <= m; ++j) terms.push_back(M[j]);
    return {{"coordinates", scene.phase_space().coordinates()}, {"magnus", strings(terms)}};
}

json modified_report(const Scene& scene, std::size_t m) {
    return {{"coordinates", scene.phase_space().coordinates()}, {"order", scene.order},
            {"modified", strings(modified_hamiltonian(scene.pi, scene.H, scene.order, scene.realisation, m))}};
}

std::string series_text(const json& r) {
    const bool magnus = r.contains("magnus");
    const auto& terms = magnus ? r["magnus"] : r["modified"];
    std::string out = magnus ? "Magnus series M_eps = sum_j eps^j M_j:\n"
                             : fmt::format("modified Hamiltonian of the order-{} scheme, Htilde = sum_j dt^j H_j:\n",
                                           r["order"].get<std::size_t>());
    for (std::size_t j = 0; j < terms.size(); ++j)
        out += fmt::format("{}_{} = {}\n", magnus ? "M" : "H", j, terms[j].get<std::string>());
    return out;
}

std::string check_text(const json& r) {
    auto verdict = [](bool b) { return b ? "hold" : "FAIL"; };
    std::string out = fmt::format("scene: {} ({})\ncoordinates: {}\nclass: {}\nskew-symmetry: holds\n",
                                  r["scene"].get<std::string>(), r["file"].get<std::string>(),
                                  fmt::join(r["coordinates"].get<std::vector<std::string>>(), ", "),
                                  r["class"].get<std::string>());
    const json& j = r["jacobi"];
    out += fmt::format("Jacobi identity: {}", j["holds"] ? "holds" : "FAILS");
    if (!j["holds"])
        out += fmt::format(" at ({}): jacobiator = {}", fmt::join(j["triple"].get<std::vector<std::string>>(), ", "),
                           j["jacobiator"].get<std::string>());
    out += "\n";
    for (const auto& c : r["casimirs"]) {
        out += fmt::format("Casimir {}: {}", c["C"].get<std::string>(), c["holds"] ? "holds" : "FAILS");
        if (!c["holds"])
            out += fmt::format(" ((pi grad C)_{} = {})", c["component"].get<std::string>(), c["value"].get<std::string>());
        out += "\n";
    }
    if (r.contains("realisation")) {
        const json& id = r["realisation"];
        out += fmt::format("realisation {}: identities {} in every p-degree below {}", id["method"].get<std::string>(),
                           verdict(id["holds"]), id["checked_below_degree"].get<std::size_t>());
        if (!id["holds"])
            out += fmt::format(" ({} fails at i = {}, j = {}, degree {}: {})", id["failure"]["identity"].get<std::string>(),
                               id["failure"]["i"].get<std::string>(), id["failure"]["j"].get<std::string>(),
                               id["failure"]["degree"].get<std::size_t>(), id["failure"]["defect"].get<std::string>());
        out += "\n";
    }
    return out;
}

std::string terms_text(const json& r) {
    std::string out = fmt::format("Hamilton-Jacobi terms, order {}, {} realisation:\n", r["order"].get<std::size_t>(),
                                  r["realisation"].get<std::string>());
    const auto& S = r["S"];
    for (std::size_t j = 0; j < S.size(); ++j) out += fmt::format("S_{} = {}\n", j + 1, S[j].get<std::string>());
    return out;
}

std::string realisation_text(const json& r) {
    std::string out = fmt::format("{} realisation truncated at p-degree {}:\n", r["realisation"].get<std::string>(),
                                  r["degree"].get<std::size_t>());
    const auto names = r["coordinates"].get<std::vector<std::string>>();
    for (std::size_t i = 0; i < names.size(); ++i)
        out += fmt::format("alpha_{} = {}\n", names[i], r["alpha"][i].get<std::string>());
    for (std::size_t i = 0; i < names.size(); ++i)
        out += fmt::format("beta_{} = {}\n", names[i], r["beta"][i].get<std::string>());
    return out;
}

}  // namespace pgi
