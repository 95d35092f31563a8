#include "tools/commands.hpp"

#include "magnus/magnus.hpp"
#include "series/message.hpp"

#include <fmt/format.h>

#include <iostream>

namespace pgi {

void say(const std::string& line) {
    std::cerr << printable(line) << "\n";
}

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

// The scene's variables as every exact report names them: its coordinates and, when it has any, its parameters with
// their exact defaults (the exact phase's polynomials are in both; the parameters are not coordinates of a run).
json variables(const Scene& scene) {
    json r{{"coordinates", scene.scheme->coordinates()}};
    if (!scene.parameters.empty()) {
        r["parameters"] = json::object();
        for (const auto& p : scene.parameters) r["parameters"][p.name] = p.value.to_string();
    }
    return r;
}

}  // namespace

json check_report(const Scene& scene) {
    const PhaseSpace& M = scene.phase_space();
    const auto& names = M.coordinates();
    const SchemeChecks& checks = scene.scheme->checks();
    json r = variables(scene);
    r.update({{"scene", scene.name},
              {"file", scene.file.string()},
              {"class", to_string(checks.structure_class)},
              {"skew", true}});
    json jacobi{{"holds", true}};
    if (!checks.jacobi_checked) jacobi = {{"holds", nullptr}, {"skipped", "--trust-jacobi"}};
    if (const auto& f = checks.jacobi)
        jacobi = {{"holds", false},
                  {"triple", {names[f->i], names[f->j], names[f->k]}},
                  {"jacobiator", f->jacobiator.to_string()}};
    r["jacobi"] = jacobi;
    r["casimirs"] = json::array();
    for (std::size_t i = 0; i < scene.casimirs.size(); ++i) {
        const Poly& C = scene.casimirs[i];
        json c{{"C", C.to_string()}, {"holds", true}};
        if (const auto& f = checks.casimirs[i])
            c = {{"C", C.to_string()},
                 {"holds", false},
                 {"component", names[f->component]},
                 {"value", f->value.to_string()}};
        r["casimirs"].push_back(c);
    }
    if (checks.realisation_checked) {
        json id{{"method", checks.realisation_method},
                {"checked_below_degree", checks.realisation_checked_below_degree},
                {"holds", true}};
        if (const auto& d = checks.realisation) {
            id["holds"] = false;
            id["failure"] = {{"identity", d->identity},
                             {"i", names[d->i]},
                             {"j", names[d->j]},
                             {"degree", d->degree},
                             {"defect", d->defect.to_string()}};
        }
        r["realisation"] = id;
    }
    r["ok"] = checks.ok();
    return r;
}

json terms_report(const Scene& scene) {
    json r = variables(scene);
    r.update({{"class", to_string(scene.pi.structure_class())},
              {"realisation", to_string(scene.scheme->realisation_form())},
              {"order", scene.order},
              {"S", strings(scene.scheme->terms())}});
    return r;
}

// The scene's coordinates' alpha and beta; a parameter's are the parameter itself (its row of pi is zero), left out.
json realisation_report(const Scene& scene, std::size_t D) {
    Realisation real = scene.scheme->realisation(D);
    const auto n = std::ptrdiff_t(scene.dim());
    const auto first = [n](std::vector<std::string> v) { return std::vector<std::string>(v.begin(), v.begin() + n); };
    json r = variables(scene);
    r.update({{"momenta", first(momenta_names(scene.phase_space()))},
              {"class", to_string(scene.pi.structure_class())},
              {"realisation", real.method},
              {"degree", D},
              {"alpha", first(strings(sums(real.alpha)))},
              {"beta", first(strings(sums(real.beta)))}});
    return r;
}

json magnus_report(const Scene& scene, std::size_t m) {
    if (!scene.magnus_h) throw SceneError(scene.file, "magnus.h", "missing: the scene has no [magnus] h");
    Series M = magnus_series(scene.pi, *scene.magnus_h, m);
    std::vector<Poly> terms;
    for (std::size_t j = 0; j <= m; ++j) terms.push_back(M[j]);
    json r = variables(scene);
    r["magnus"] = strings(terms);
    return r;
}

json modified_report(const Scene& scene, std::size_t m) {
    json r = variables(scene);
    r.update({{"order", scene.order}, {"modified", strings(scene.scheme->modified_hamiltonian(m))}});
    return r;
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
    std::string out =
        fmt::format("scene: {} ({})\ncoordinates: {}\n", r["scene"].get<std::string>(), r["file"].get<std::string>(),
                    fmt::join(r["coordinates"].get<std::vector<std::string>>(), ", "));
    if (r.contains("parameters")) {
        std::vector<std::string> w;
        for (const auto& [name, value] : r["parameters"].items()) w.push_back(name + " = " + value.get<std::string>());
        out += fmt::format("parameters: {}\n", fmt::join(w, ", "));
    }
    out += fmt::format("class: {}\nskew-symmetry: holds\n", r["class"].get<std::string>());
    const json& j = r["jacobi"];
    if (j.contains("skipped"))
        out += "Jacobi identity: not checked (--trust-jacobi)";
    else
        out += fmt::format("Jacobi identity: {}", j["holds"] ? "holds" : "FAILS");
    if (j["holds"] == false)
        out += fmt::format(" at ({}): jacobiator = {}", fmt::join(j["triple"].get<std::vector<std::string>>(), ", "),
                           j["jacobiator"].get<std::string>());
    out += "\n";
    for (const auto& c : r["casimirs"]) {
        out += fmt::format("Casimir {}: {}", c["C"].get<std::string>(), c["holds"] ? "holds" : "FAILS");
        if (!c["holds"])
            out +=
                fmt::format(" ((pi grad C)_{} = {})", c["component"].get<std::string>(), c["value"].get<std::string>());
        out += "\n";
    }
    if (r.contains("realisation")) {
        const json& id = r["realisation"];
        out += fmt::format("realisation {}: identities {} in every p-degree below {}", id["method"].get<std::string>(),
                           verdict(id["holds"]), id["checked_below_degree"].get<std::size_t>());
        if (!id["holds"])
            out += fmt::format(" ({} fails at i = {}, j = {}, degree {}: {})",
                               id["failure"]["identity"].get<std::string>(), id["failure"]["i"].get<std::string>(),
                               id["failure"]["j"].get<std::string>(), id["failure"]["degree"].get<std::size_t>(),
                               id["failure"]["defect"].get<std::string>());
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
