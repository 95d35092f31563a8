// pgi report: one document per scene, as JSON, Markdown or LaTeX.
#include "tools/commands.hpp"

#include "magnus/polynomial_in.hpp"
#include "series/latex.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

namespace pgi {

using nlohmann::json;

namespace {

// the room of an align* row right of "lhs &= " on an A4 page with 2 cm margins at 11pt (44 em of text), less
// the left column and the continuation's \quad: measured with pdflatex on the Volterra and Henon-Heiles reports
constexpr double line_em = 36;

// "latex" inline; "latex_lines" broken by width at + and - signs, for align* rows
json poly_entry(const Poly& f) {
    return {{"text", f.to_string()}, {"latex", to_latex(f)}, {"latex_lines", latex_lines(f, line_em, line_em - 1)}};
}

json poly_entries(const std::vector<Poly>& v) {
    json a = json::array();
    for (const auto& f : v) a.push_back(poly_entry(f));
    return a;
}

// The UTF-8 sequence at s[i] (advancing i past it): its code point, or U+FFFD for a malformed one (one byte skipped).
char32_t next_code_point(const std::string& s, std::size_t& i) {
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned char b = byte(i);
    const int extra = b < 0x80 ? 0 : (b >> 5) == 0x6 ? 1 : (b >> 4) == 0xE ? 2 : (b >> 3) == 0x1E ? 3 : -1;
    if (extra < 0 || i + std::size_t(extra) >= s.size()) return ++i, U'\uFFFD';
    char32_t c = extra == 0 ? b : b & (0x3F >> extra);
    for (int k = 1; k <= extra; ++k) {
        if ((byte(i + std::size_t(k)) & 0xC0) != 0x80) return ++i, U'\uFFFD';
        c = (c << 6) | (byte(i + std::size_t(k)) & 0x3F);
    }
    i += std::size_t(extra) + 1;
    return c;
}

// Text for LaTeX: its special characters escaped; a character outside ASCII as itself where pdflatex's default UTF-8
// input sets it up for its default fonts (Latin-1's letters, dashes and quotes), else (a control character too) as its
// code point, \texttt{U+525B}: pdflatex stops at the first character it has not set up, and a scene's name may hold
// any.
std::string latex_escape(const std::string& s) {
    std::string out;
    for (std::size_t i = 0; i < s.size();) {
        const std::size_t start = i;
        const char32_t c = next_code_point(s, i);
        if (c >= 0x80 || c < 0x20 || c == 0x7F) {
            const bool set_up = (c >= 0xC0 && c <= 0xFF && c != 0xD7 && c != 0xF7) || (c >= 0x2013 && c <= 0x2014) ||
                                (c >= 0x2018 && c <= 0x201D);
            out += set_up ? s.substr(start, i - start) : fmt::format("\\texttt{{U+{:04X}}}", std::uint32_t(c));
            continue;
        }
        const char a = char(c);
        if (std::string("#$%&_{}").find(a) != std::string::npos) out += '\\';
        if (a == '\\')
            out += "\\textbackslash{}";
        else if (a == '^')
            out += "\\^{}";
        else if (a == '~')
            out += "\\~{}";
        else
            out += a;
    }
    return out;
}

// the H_j (j >= 1, non-zero) that are polynomials in H and the Casimirs: {"j", "text", "latex"}
json in_invariants(const Scene& scene, const std::vector<Poly>& Ht) {
    std::vector<Poly> G{scene.H};
    std::vector<std::string> names{"H"};
    for (std::size_t c = 0; c < scene.casimirs.size(); ++c) {
        G.push_back(scene.casimirs[c]);
        names.push_back(fmt::format("C{}", c + 1));  // ("C" + std::to_string: a GCC 12 -Wrestrict false positive)
    }
    json found = json::array();
    if (scene.H.total_degree() < 1) return found;
    for (std::size_t j = 1; j < Ht.size(); ++j) {
        if (Ht[j].is_zero()) continue;
        if (auto Q = as_polynomial_in(Ht[j], G, names))
            found.push_back({{"j", j}, {"text", Q->to_string()}, {"latex", to_latex(*Q)}});
    }
    return found;
}

}  // namespace

json report_data(const Scene& scene, std::size_t m) {
    const PhaseSpace& M = scene.phase_space();
    const auto& names = M.coordinates();
    json brackets = json::array();
    for (std::size_t i = 0; i < M.dim(); ++i)
        for (std::size_t j = i + 1; j < M.dim(); ++j)
            if (!scene.pi(i, j).is_zero())
                brackets.push_back({{"i", names[i]},
                                    {"j", names[j]},
                                    {"i_latex", latex_name(names[i])},
                                    {"j_latex", latex_name(names[j])},
                                    {"value", poly_entry(scene.pi(i, j))}});
    // the realisation at the deepest p-degree this report reads (the checks need k, Htilde m), built once
    scene.scheme->realisation(std::max(m, scene.order));
    const auto Ht = scene.scheme->modified_hamiltonian(m);
    const std::vector<Poly>& S = scene.scheme->terms();
    json r{{"scene", scene.name},
           {"file", scene.file.string()},
           {"coordinates", names},
           {"brackets", brackets},
           {"H", poly_entry(scene.H)},
           {"casimirs", poly_entries(scene.casimirs)},
           {"check", check_report(scene)},
           {"order", scene.order},
           {"method_order", scene.scheme->method_order()},
           {"realisation", to_string(scene.scheme->realisation_form())},
           {"S", poly_entries(S)},
           {"modified", poly_entries(Ht)},
           {"modified_upto", m}};
    r["modified_in_invariants"] = in_invariants(scene, Ht);
    if (scene.splitting_A) {
        r["splitting"] = json::array();
        for (auto method : {SplittingMethod::lie_trotter, SplittingMethod::strang, SplittingMethod::yoshida}) {
            json s = splitting_report(scene, method, m, [](const Poly& P) { return poly_entry(P); });
            s["A"] = poly_entry(*scene.splitting_A);
            r["splitting"].push_back(s);
        }
    }
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
    std::string out =
        fmt::format("# {}\n\nScene `{}`, coordinates {}.\n\n## Poisson structure\n\n", r["scene"].get<std::string>(),
                    r["file"].get<std::string>(), fmt::join(r["coordinates"].get<std::vector<std::string>>(), ", "));
    for (const auto& b : r["brackets"])
        out += fmt::format("- {{{}, {}}} = `{}`\n", b["i"].get<std::string>(), b["j"].get<std::string>(),
                           b["value"]["text"].get<std::string>());
    const json& c = r["check"];
    out += fmt::format("\nClass: {}. Jacobi identity: {}. ", c["class"].get<std::string>(),
                       c["jacobi"]["holds"] ? "holds" : "FAILS");
    for (const auto& cas : c["casimirs"])
        out += fmt::format("Casimir `{}`: {}. ", cas["C"].get<std::string>(), cas["holds"] ? "holds" : "FAILS");
    out += fmt::format(
        "\n\nHamiltonian: `H = {}`\n\n## Integrator\n\nHamilton-Jacobi order k = {} (a method of order {}), {} "
        "realisation",
        r["H"]["text"].get<std::string>(), r["order"].get<std::size_t>(), r["method_order"].get<std::size_t>(),
        r["realisation"].get<std::string>());
    if (c.contains("realisation"))
        out +=
            fmt::format(" (realisation identities {} below p-degree {})", c["realisation"]["holds"] ? "hold" : "FAIL",
                        c["realisation"]["checked_below_degree"].get<std::size_t>());
    out += ".\n\n";
    for (std::size_t j = 0; j < r["S"].size(); ++j)
        out += fmt::format("- `S_{} = {}`\n", j + 1, r["S"][j]["text"].get<std::string>());
    out += fmt::format(
        "\n## Modified Hamiltonian\n\nHtilde = H_0 + dt H_1 + ... + dt^{} H_{} + O(dt^{}), exact over Q (unique modulo "
        "Casimirs):\n\n",
        r["modified_upto"].get<std::size_t>(), r["modified_upto"].get<std::size_t>(),
        r["modified_upto"].get<std::size_t>() + 1);
    for (std::size_t j = 0; j < r["modified"].size(); ++j)
        out += fmt::format("- `H_{} = {}`\n", j, r["modified"][j]["text"].get<std::string>());
    if (!r["modified_in_invariants"].empty()) {
        std::vector<std::string> forms;
        for (const auto& f : r["modified_in_invariants"])
            forms.push_back(fmt::format("`H_{} = {}`", f["j"].get<std::size_t>(), f["text"].get<std::string>()));
        out += fmt::format("\nIn terms of H and the Casimirs C1, C2, ... (in the order listed), exactly: {}.\n",
                           fmt::join(forms, ", "));
    }
    if (r.contains("splitting")) {
        out += fmt::format(
            "\n## Splitting methods\n\nH = A + B with A = `{}`; exact BCH series in Poisson brackets "
            "(Yoshida's in Q(w), w = 1/(2 - 2^(1/3)): H_j = P_j0 + w P_j1 + w^2 P_j2):\n",
            r["splitting"][0]["A"]["text"].get<std::string>());
        for (const auto& s : r["splitting"]) {
            out += fmt::format("\n### {} (order {})\n\n", s["splitting"].get<std::string>(),
                               s["method_order"].get<std::size_t>());
            for (std::size_t j = 0; j < s["modified"].size(); ++j) {
                const json& c = s["modified"][j];
                const bool zero = std::all_of(c.begin(), c.end(), [](const json& p) { return p["text"] == "0"; });
                for (std::size_t k = 0; k < c.size(); ++k)
                    if (c[k]["text"] != "0" || (k == 0 && (c.size() == 1 || zero)))
                        out += fmt::format("- `{} = {}`\n",
                                           c.size() == 1 || zero ? fmt::format("H_{}", j) : fmt::format("P_{}{}", j, k),
                                           c[k]["text"].get<std::string>());
            }
            const json& run = s["run"];
            if (run.contains("skipped"))
                out += fmt::format("\nNo numerical check: {}.\n", run["skipped"].get<std::string>());
            else
                out += fmt::format(
                    "\nRun with exact flows ({} steps of dt = {}): max relative error of H {:.3e} (order {:.2f} "
                    "measured at dt/2), of Htilde {:.3e} (order {:.2f}, {} expected).\n",
                    run["steps"].get<std::size_t>(), run["dt"].get<double>(), run["energy_error_max"].get<double>(),
                    run["energy_order_measured"].get<double>(), run["modified_energy_error_max"].get<double>(),
                    run["modified_order_measured"].get<double>(), run["modified_order_expected"].get<std::size_t>());
        }
    }
    if (r.contains("run")) {
        const json& run = r["run"];
        out += fmt::format(
            "\n## Numerical check\n\n{} steps of dt = {} to t = {}: max relative error of H {:.3e}, of Htilde through "
            "dt^{} {:.3e}",
            run["steps"].get<std::size_t>(), run["dt"].get<double>(), run["t"].get<double>(),
            run["energy_error_max"].get<double>(), r["modified_upto"].get<std::size_t>(),
            run["modified_energy_error_max"].get<double>());
        for (std::size_t i = 0; i < run["casimir_error_max"].size(); ++i)
            out += fmt::format(", of the Casimir `{}` {:.3e}", r["casimirs"][i]["text"].get<std::string>(),
                               run["casimir_error_max"][i].get<double>());
        out += fmt::format("; {:.2f} Newton iterations per step.\n", run["newton_iterations_mean"].get<double>());
    }
    return out;
}

namespace {

// the rows "lhs &= line \\ &\quad line ..." of one polynomial in an align* block
std::string align_rows(const std::string& lhs, const json& entry) {
    std::string out;
    const auto& lines = entry["latex_lines"];
    for (std::size_t i = 0; i < lines.size(); ++i)
        out += (i == 0 ? lhs + " &= " : " \\\\\n  &\\quad ") + lines[i].get<std::string>();
    return out;
}

// an align* block of rows, or nothing
std::string align_block(const std::vector<std::string>& rows) {
    if (rows.empty()) return "";
    std::string out = "\\begin{align*}\n";
    for (std::size_t i = 0; i < rows.size(); ++i) out += rows[i] + (i + 1 < rows.size() ? " \\\\\n" : "\n");
    return out + "\\end{align*}\n";
}

// "H_1 = H_2 = H_3 = 0" for the zero terms, rows for the others
std::string series_block(const std::string& symbol, const json& terms) {
    std::vector<std::string> rows, zeros;
    for (std::size_t j = 0; j < terms.size(); ++j) {
        const std::string lhs = fmt::format("{}_{{{}}}", symbol, j);
        if (terms[j]["text"] == "0")
            zeros.push_back(lhs);
        else
            rows.push_back(align_rows(lhs, terms[j]));
    }
    std::string out = align_block(rows);
    if (!zeros.empty()) out += fmt::format("and ${} = 0$.\n", fmt::join(zeros, " = "));
    return out;
}

std::string splitting_latex(const json& s) {
    const json& run = s["run"];
    const std::string name = s["splitting"] == "lie-trotter" ? "Lie--Trotter"
                             : s["splitting"] == "strang"    ? "Strang"
                                                             : "Yoshida";
    std::string out = fmt::format("\\paragraph{{{} (order {}).}}\n", name, s["method_order"].get<std::size_t>());
    if (s["splitting"] == "lie-trotter")
        out += "One step is the flow of $A$ for $\\Delta t$, then the flow of $B$ for $\\Delta t$.\n";
    if (s["splitting"] == "strang")
        out += "One step is the flows of $A$ for $\\Delta t/2$, $B$ for $\\Delta t$, $A$ for $\\Delta t/2$.\n";
    if (s["splitting"] == "yoshida")
        out +=
            "One step is Strang's with steps $w\\Delta t$, $(1-2w)\\Delta t$, $w\\Delta t$, $w = 1/(2 - 2^{1/3})$, the "
            "real root of "
            "$6w^3 - 12w^2 + 6w - 1$; the series lies in $\\mathbb{Q}(w)$ and is shown as $H_j = P_{j,0} + w P_{j,1} + "
            "w^2 P_{j,2}$.\n";
    if (s["splitting"] == "yoshida") {
        std::vector<std::string> rows, zeros;
        for (std::size_t j = 0; j < s["modified"].size(); ++j) {
            const json& c = s["modified"][j];
            if (std::all_of(c.begin(), c.end(), [](const json& p) { return p["text"] == "0"; })) {
                zeros.push_back(fmt::format("H_{{{}}}", j));
                continue;
            }
            for (std::size_t k = 0; k < c.size(); ++k)
                if (c[k]["text"] != "0") rows.push_back(align_rows(fmt::format("P_{{{},{}}}", j, k), c[k]));
        }
        out += align_block(rows);
        if (!zeros.empty()) out += fmt::format("and ${} = 0$.\n", fmt::join(zeros, " = "));
    } else {
        json terms = json::array();
        for (const auto& c : s["modified"]) terms.push_back(c[0]);
        out += series_block("H", terms);
    }
    if (run.contains("skipped"))
        out += fmt::format("No numerical check: {}.\n", latex_escape(run["skipped"].get<std::string>()));
    else
        out += fmt::format(
            "Run of the splitting with the exact flows of $A$ and $B$ ({} steps of $\\Delta t = {}$): maximum relative "
            "error of $H$ ${}$ (order {:.2f} measured against $\\Delta t/2$), of $\\tilde H$ through $\\Delta "
            "t^{{{}}}$ ${}$ "
            "(order {:.2f} measured, {} expected).\n",
            run["steps"].get<std::size_t>(), latex_number(run["dt"].get<double>()),
            latex_number(run["energy_error_max"].get<double>()), run["energy_order_measured"].get<double>(),
            s["modified"].size() - 1, latex_number(run["modified_energy_error_max"].get<double>()),
            run["modified_order_measured"].get<double>(), run["modified_order_expected"].get<std::size_t>());
    return out;
}

}  // namespace

std::string report_latex(const json& r) {
    std::string out =
        "\\documentclass[11pt,a4paper]{article}\n\\usepackage{amsmath,amssymb}\n\\usepackage[margin=2cm]{geometry}\n"
        "\\allowdisplaybreaks\n\\begin{document}\n";
    std::vector<std::string> coords;
    for (const auto& c : r["coordinates"]) coords.push_back(latex_name(c.get<std::string>()));
    out += fmt::format(
        "\\section*{{{}}}\nScene file \\texttt{{{}}}, coordinates ${}$; brackets $\\{{f, g\\}} = \\nabla f^T \\pi\\, "
        "\\nabla g$, "
        "flows $\\dot x = \\{{x, H\\}}$.\n",
        latex_escape(r["scene"].get<std::string>()),
        latex_escape(std::filesystem::path(r["file"].get<std::string>()).filename().string()), fmt::join(coords, ", "));
    out +=
        "\\subsection*{Poisson structure}\nThe non-zero brackets of the coordinates ($i < j$) and the Hamiltonian:\n";
    std::vector<std::string> rows;
    for (const auto& b : r["brackets"])
        rows.push_back(
            align_rows(fmt::format("\\{{{}, {}\\}}", b["i_latex"].get<std::string>(), b["j_latex"].get<std::string>()),
                       b["value"]));
    rows.push_back(align_rows("H", r["H"]));
    out += align_block(rows);
    const json& c = r["check"];
    out += fmt::format("Class: {}; the Jacobi identity {}", latex_escape(c["class"].get<std::string>()),
                       c["jacobi"]["holds"] ? "holds" : "fails");
    for (std::size_t i = 0; i < r["casimirs"].size(); ++i)
        out += fmt::format("; $C_{{{}}} = {}$ is {}a Casimir", i + 1, r["casimirs"][i]["latex"].get<std::string>(),
                           c["casimirs"][i]["holds"] ? "" : "not ");
    out += fmt::format(
        ".\n\\subsection*{{Hamilton--Jacobi terms}}\nOrder $k = {}$ (a method of order {}), {} realisation; the step's "
        "generating function is $S_t = \\sum_{{j=1}}^{{k}} t^j S_j$.\n",
        r["order"].get<std::size_t>(), r["method_order"].get<std::size_t>(),
        latex_escape(r["realisation"].get<std::string>()));
    std::vector<std::string> srows, zeros;
    for (std::size_t j = 0; j < r["S"].size(); ++j) {
        const std::string lhs = fmt::format("S_{{{}}}", j + 1);
        if (r["S"][j]["text"] == "0")
            zeros.push_back(lhs);
        else
            srows.push_back(align_rows(lhs, r["S"][j]));
    }
    out += align_block(srows);
    if (!zeros.empty()) out += fmt::format("and ${} = 0$.\n", fmt::join(zeros, " = "));
    const auto m = r["modified_upto"].get<std::size_t>();
    out += fmt::format(
        "\\subsection*{{Modified Hamiltonian}}\nThe time-$\\Delta t$ flow of $\\tilde H = \\sum_{{j=0}}^{{{}}} \\Delta "
        "t^j H_j "
        "+ O(\\Delta t^{{{}}})$ is one step of the scheme to that order; the $H_j$ are exact over $\\mathbb{{Q}}$ and "
        "unique modulo Casimirs.\n",
        m, m + 1);
    out += series_block("H", r["modified"]);
    if (!r["modified_in_invariants"].empty()) {
        std::vector<std::string> forms;
        for (const auto& f : r["modified_in_invariants"])
            forms.push_back(fmt::format("$H_{{{}}} = {}$", f["j"].get<std::size_t>(), f["latex"].get<std::string>()));
        out += fmt::format(
            "In terms of $H${} (found by exact linear algebra over $\\mathbb{{Q}}$ on the monomials): {}.\n",
            r["casimirs"].empty() ? "" : " and the Casimirs $C_i$ listed above", fmt::join(forms, ", "));
    }
    if (r.contains("splitting")) {
        out += fmt::format(
            "\\subsection*{{Splitting methods}}\nWith $H = A + B$, $A = {}$ and $B = H - A$, the modified Hamiltonians "
            "of "
            "three splitting methods, from the Baker--Campbell--Hausdorff series in Poisson brackets (exact):\n",
            r["splitting"][0]["A"]["latex"].get<std::string>());
        for (const auto& s : r["splitting"]) out += splitting_latex(s);
    }
    if (r.contains("run")) {
        const json& run = r["run"];
        out += fmt::format(
            "\\subsection*{{Numerical check}}\n{} steps of $\\Delta t = {}$ to $t = {}$: maximum relative error of $H$ "
            "${}$, "
            "of $\\tilde H$ through $\\Delta t^{{{}}}$ ${}$",
            run["steps"].get<std::size_t>(), latex_number(run["dt"].get<double>()),
            latex_number(run["t"].get<double>()), latex_number(run["energy_error_max"].get<double>()), m,
            latex_number(run["modified_energy_error_max"].get<double>()));
        for (std::size_t i = 0; i < run["casimir_error_max"].size(); ++i)
            out += fmt::format(", of $C_{{{}}}$ ${}$", i + 1, latex_number(run["casimir_error_max"][i].get<double>()));
        out += fmt::format("; {:.2f} Newton iterations per step.\n", run["newton_iterations_mean"].get<double>());
    }
    out += "\\end{document}\n";
    return out;
}

}  // namespace pgi
