// pgi report: one document per scene, as JSON, Markdown or LaTeX.
#include "tools/commands.hpp"

#include "series/latex.hpp"

#include <fmt/format.h>

namespace pgi {

using nlohmann::json;

namespace {

// "latex" inline; "latex_lines" broken every six terms, for align environments
json poly_entry(const Poly& f) {
    return {{"text", f.to_string()}, {"latex", to_latex(f)}, {"latex_lines", to_latex(f, 6, " \\\\\n  &\\quad ")}};
}

json poly_entries(const std::vector<Poly>& v) {
    json a = json::array();
    for (const auto& f : v) a.push_back(poly_entry(f));
    return a;
}

std::string latex_escape(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (std::string("#$%&_{}").find(c) != std::string::npos) out += '\\';
        if (c == '\\') out += "\\textbackslash{}";
        else if (c == '^') out += "\\^{}";
        else if (c == '~') out += "\\~{}";
        else out += c;
    }
    return out;
}

}  // namespace

json report_data(const Scene& scene, std::size_t m) {
    const PhaseSpace& M = scene.phase_space();
    const auto& names = M.coordinates();
    json brackets = json::array();
    for (std::size_t i = 0; i < M.dim(); ++i)
        for (std::size_t j = i + 1; j < M.dim(); ++j)
            if (!scene.pi(i, j).is_zero())
                brackets.push_back({{"i", names[i]}, {"j", names[j]}, {"i_latex", latex_name(names[i])},
                                    {"j_latex", latex_name(names[j])}, {"value", poly_entry(scene.pi(i, j))}});
    // the realisation at the deepest p-degree this report reads (the checks need k, Htilde m), built once
    scene.scheme->realisation(std::max(m, scene.order));
    const auto Ht = scene.scheme->modified_hamiltonian(m);
    const std::vector<Poly>& S = scene.scheme->terms();
    json r{{"scene", scene.name}, {"file", scene.file.string()}, {"coordinates", names}, {"brackets", brackets},
           {"H", poly_entry(scene.H)}, {"casimirs", poly_entries(scene.casimirs)}, {"check", check_report(scene)},
           {"order", scene.order}, {"method_order", scene.scheme->method_order()},
           {"realisation", to_string(scene.scheme->realisation_form())},
           {"S", poly_entries(S)}, {"modified", poly_entries(Ht)}, {"modified_upto", m}};
    if (scene.x0 && scene.t_end) {
        IntegrateOptions options;
        options.modified = sum_powers(Ht, Rational::from_double(scene.dt));  // Htilde at the scene's dt
        json run = integrate_report(scene, options);
        r["run"] = {{"dt", scene.dt},
                    {"steps", run["steps"]},
                    {"t", run["t"]},
                    {"energy_error_max", run["energy_error_max"]},
                    {"modified_energy_error_max", run["modified_energy_error_max"]},
                    {"casimir_error_max", run["casimir_error_max"]},
                    {"newton_iterations_mean", run["newton_iterations_mean"]}};
    }
    return r;
}

std::string report_markdown(const json& r) {
    std::string out = fmt::format("# {}\n\nScene `{}`, coordinates {}.\n\n## Poisson structure\n\n", r["scene"].get<std::string>(),
                                  r["file"].get<std::string>(), fmt::join(r["coordinates"].get<std::vector<std::string>>(), ", "));
    for (const auto& b : r["brackets"])
        out += fmt::format("- {{{}, {}}} = `{}`\n", b["i"].get<std::string>(), b["j"].get<std::string>(),
                           b["value"]["text"].get<std::string>());
    const json& c = r["check"];
    out += fmt::format("\nClass: {}. Jacobi identity: {}. ", c["class"].get<std::string>(), c["jacobi"]["holds"] ? "holds" : "FAILS");
    for (const auto& cas : c["casimirs"])
        out += fmt::format("Casimir `{}`: {}. ", cas["C"].get<std::string>(), cas["holds"] ? "holds" : "FAILS");
    out += fmt::format("\n\nHamiltonian: `H = {}`\n\n## Integrator\n\nHamilton-Jacobi order k = {} (a method of order {}), {} realisation",
                       r["H"]["text"].get<std::string>(), r["order"].get<std::size_t>(), r["method_order"].get<std::size_t>(),
                       r["realisation"].get<std::string>());
    if (c.contains("realisation"))
        out += fmt::format(" (realisation identities {} below p-degree {})", c["realisation"]["holds"] ? "hold" : "FAIL",
                           c["realisation"]["checked_below_degree"].get<std::size_t>());
    out += ".\n\n";
    for (std::size_t j = 0; j < r["S"].size(); ++j) out += fmt::format("- `S_{} = {}`\n", j + 1, r["S"][j]["text"].get<std::string>());
    out += fmt::format("\n## Modified Hamiltonian\n\nHtilde = H_0 + dt H_1 + ... + dt^{} H_{} + O(dt^{}), exact over Q (unique modulo Casimirs):\n\n",
                       r["modified_upto"].get<std::size_t>(), r["modified_upto"].get<std::size_t>(), r["modified_upto"].get<std::size_t>() + 1);
    for (std::size_t j = 0; j < r["modified"].size(); ++j)
        out += fmt::format("- `H_{} = {}`\n", j, r["modified"][j]["text"].get<std::string>());
    if (r.contains("run")) {
        const json& run = r["run"];
        out += fmt::format("\n## Numerical check\n\n{} steps of dt = {} to t = {}: max relative error of H {:.3e}, of Htilde through dt^{} {:.3e}",
                           run["steps"].get<std::size_t>(), run["dt"].get<double>(), run["t"].get<double>(),
                           run["energy_error_max"].get<double>(), r["modified_upto"].get<std::size_t>(),
                           run["modified_energy_error_max"].get<double>());
        for (const auto& e : run["casimir_error_max"]) out += fmt::format(", of a Casimir {:.3e}", e.get<double>());
        out += fmt::format("; {:.2f} Newton iterations per step.\n", run["newton_iterations_mean"].get<double>());
    }
    return out;
}

std::string report_latex(const json& r) {
    std::string out = "\\documentclass[11pt]{article}\n\\usepackage{amsmath,amssymb}\n\\usepackage[margin=2cm]{geometry}\n\\begin{document}\n";
    out += fmt::format("\\section*{{{}}}\n", latex_escape(r["scene"].get<std::string>()));
    out += "\\subsection*{Poisson structure}\n\\begin{align*}\n";
    for (const auto& b : r["brackets"])
        out += fmt::format("\\{{{}, {}\\}} &= {} \\\\\n", b["i_latex"].get<std::string>(), b["j_latex"].get<std::string>(),
                           b["value"]["latex_lines"].get<std::string>());
    out += fmt::format("H &= {}\n\\end{{align*}}\n", r["H"]["latex_lines"].get<std::string>());
    const json& c = r["check"];
    out += fmt::format("Class: {}; the Jacobi identity {}", latex_escape(c["class"].get<std::string>()),
                       c["jacobi"]["holds"] ? "holds" : "fails");
    for (std::size_t i = 0; i < r["casimirs"].size(); ++i)
        out += fmt::format("; ${}$ is {}a Casimir", r["casimirs"][i]["latex"].get<std::string>(), c["casimirs"][i]["holds"] ? "" : "not ");
    out += fmt::format(".\n\\subsection*{{Hamilton--Jacobi terms}}\nOrder $k = {}$ (a method of order {}), {} realisation.\n\\begin{{align*}}\n",
                       r["order"].get<std::size_t>(), r["method_order"].get<std::size_t>(), latex_escape(r["realisation"].get<std::string>()));
    for (std::size_t j = 0; j < r["S"].size(); ++j)
        out += fmt::format("S_{{{}}} &= {}{}\n", j + 1, r["S"][j]["latex_lines"].get<std::string>(), j + 1 < r["S"].size() ? " \\\\" : "");
    out += "\\end{align*}\n\\subsection*{Modified Hamiltonian}\n";
    out += fmt::format("$\\tilde H = \\sum_{{j=0}}^{{{}}} \\Delta t^j H_j + O(\\Delta t^{{{}}})$, exact over $\\mathbb{{Q}}$, unique modulo Casimirs:\n\\begin{{align*}}\n",
                       r["modified_upto"].get<std::size_t>(), r["modified_upto"].get<std::size_t>() + 1);
    for (std::size_t j = 0; j < r["modified"].size(); ++j)
        out += fmt::format("H_{{{}}} &= {}{}\n", j, r["modified"][j]["latex_lines"].get<std::string>(), j + 1 < r["modified"].size() ? " \\\\" : "");
    out += "\\end{align*}\n";
    if (r.contains("run")) {
        const json& run = r["run"];
        out += fmt::format("\\subsection*{{Numerical check}}\n{} steps of $\\Delta t = {}$ to $t = {}$: maximum relative error of $H$ ${}$, of $\\tilde H$ through $\\Delta t^{{{}}}$ ${}$.\n",
                           run["steps"].get<std::size_t>(), run["dt"].get<double>(), run["t"].get<double>(),
                           fmt::format("{:.3e}", run["energy_error_max"].get<double>()), r["modified_upto"].get<std::size_t>(),
                           fmt::format("{:.3e}", run["modified_energy_error_max"].get<double>()));
    }
    out += "\\end{document}\n";
    return out;
}

}  // namespace pgi
