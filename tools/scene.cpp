#include "tools/scene.hpp"

#include <toml++/toml.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace pgi {

namespace {

// Reads one scene file; every error names the file and the key.
class SceneReader {
public:
    SceneReader(std::filesystem::path file, const SceneOverrides& overrides) : file_(std::move(file)), ov_(overrides) {}

    Scene read() { return read_text(file_text()); }

    Scene read_text(std::string_view text) {
        toml::table doc = parse_document(text);
        check_keys(doc, "", {"name", "coordinates", "brackets", "hamiltonian", "integrator", "run", "magnus"});
        std::string name = string_at(doc, "name", true).value_or("");
        PhaseSpace M(read_coordinates(doc), budget());
        PoissonStructure pi = read_brackets(doc, M);
        const toml::table& ham = table_at(doc, "hamiltonian", true);
        check_keys(ham, "hamiltonian", {"H", "casimirs"});
        Poly H = poly(M, "hamiltonian.H", *string_at(ham, "H", true, "hamiltonian."));
        std::vector<Poly> casimirs;
        if (const toml::node* c = ham.get("casimirs")) {
            const toml::array* arr = c->as_array();
            if (!arr) fail("hamiltonian.casimirs", "must be a list of polynomial strings");
            for (std::size_t i = 0; i < arr->size(); ++i) {
                std::string key = "hamiltonian.casimirs[" + std::to_string(i) + "]";
                auto s = (*arr)[i].value<std::string>();
                if (!(*arr)[i].is_string()) fail(key, "must be a polynomial string");
                casimirs.push_back(poly(M, key, *s));
            }
        }
        Scene scene{file_, name, std::move(pi), std::move(H), std::move(casimirs), 2, 0.1, "1/10", RealisationChoice::automatic, std::nullopt, std::nullopt, std::nullopt};
        read_integrator(doc, scene);
        read_run(doc, scene);
        read_magnus(doc, scene);
        return scene;
    }

private:
    [[noreturn]] void fail(const std::string& key, const std::string& problem) const { throw SceneError(file_, key, problem); }

    std::string file_text() const {
        std::ifstream in(file_, std::ios::binary);
        if (!in) fail("", std::string("cannot read the file (") + std::strerror(errno) + ")");
        std::stringstream buffer;
        buffer << in.rdbuf();
        if (in.bad()) fail("", "cannot read the file");
        return buffer.str();
    }

    toml::table parse_document(std::string_view text) const {
        try {
            return toml::parse(text, file_.string());
        } catch (const toml::parse_error& e) {
            fail("", "TOML syntax error at line " + std::to_string(e.source().begin.line) + ", column " +
                         std::to_string(e.source().begin.column) + ": " + std::string(e.description()));
        }
    }

    void check_keys(const toml::table& t, const std::string& where, std::set<std::string> known) const {
        for (const auto& [k, v] : t)
            if (!known.count(std::string(k.str())))
                fail(where.empty() ? std::string(k.str()) : where + "." + std::string(k.str()), "unknown key");
    }

    const toml::table& table_at(const toml::table& t, const std::string& key, bool required) const {
        static const toml::table empty;
        const toml::node* n = t.get(key);
        if (!n) {
            if (required) fail(key, "missing table [" + key + "]");
            return empty;
        }
        if (!n->is_table()) fail(key, "must be a table [" + key + "]");
        return *n->as_table();
    }

    std::optional<std::string> string_at(const toml::table& t, const std::string& key, bool required,
                                         const std::string& prefix = "") const {
        const toml::node* n = t.get(key);
        if (!n) {
            if (required) fail(prefix + key, "missing key");
            return std::nullopt;
        }
        if (!n->is_string()) fail(prefix + key, "must be a string");
        return n->value<std::string>();
    }

    // The budget of the scene's exact phase, from the overrides (it starts its clock now).
    std::shared_ptr<const Budget> budget() const {
        BudgetLimits limits{.max_terms = ov_.max_terms, .max_seconds = ov_.max_seconds};
        if (ov_.max_memory_mb != 0) limits.max_bytes = std::min<std::size_t>(ov_.max_memory_mb, SIZE_MAX >> 20) << 20;
        return std::make_shared<const Budget>(limits, ov_.progress);
    }

    Poly poly(const PhaseSpace& M, const std::string& key, const std::string& text) const {
        try {
            return M.parse(text);
        } catch (const ResourceLimitError& e) {  // a budget refusal stays one (exit 4), naming the key
            throw ParseBudgetError(file_.string() + ": " + key + ": " + e.what());
        } catch (const std::exception& e) {
            fail(key, e.what());
        }
    }

    std::vector<std::string> read_coordinates(const toml::table& doc) const {
        const toml::node* n = doc.get("coordinates");
        if (!n) fail("coordinates", "missing key");
        const toml::array* arr = n->as_array();
        if (!arr || arr->empty()) fail("coordinates", "must be a non-empty list of names");
        std::vector<std::string> names;
        for (std::size_t i = 0; i < arr->size(); ++i) {
            std::string key = "coordinates[" + std::to_string(i) + "]";
            if (!(*arr)[i].is_string()) fail(key, "must be a string");
            std::string s = *(*arr)[i].value<std::string>();
            if (s.empty()) fail(key, "empty coordinate name");
            if (s == "t") fail(key, "'t' is reserved for the time step");
            for (const auto& prev : names)
                if (prev == s) fail(key, "duplicate coordinate '" + s + "'");
            names.push_back(std::move(s));
        }
        try {
            Ring check(names);  // identifier syntax
        } catch (const std::exception& e) {
            fail("coordinates", e.what());
        }
        return names;
    }

    PoissonStructure read_brackets(const toml::table& doc, const PhaseSpace& M) const {
        const toml::table& br = table_at(doc, "brackets", true);
        const std::size_t n = M.dim();
        std::vector<std::vector<std::optional<Poly>>> given(n, std::vector<std::optional<Poly>>(n));
        for (const auto& [k, v] : br) {
            std::string key = "brackets.\"" + std::string(k.str()) + "\"";
            auto [i, j] = bracket_pair(key, std::string(k.str()), M);
            if (!v.is_string()) fail(key, "must be a polynomial string");
            Poly f = poly(M, key, *v.value<std::string>());
            if (i == j) {
                if (!f.is_zero()) fail(key, "not skew: {" + M.coordinates()[i] + "," + M.coordinates()[i] + "} must be 0");
                continue;
            }
            // {a,b} given as f means pi_ab = f and pi_ba = -f
            for (auto [a, b, value] : {std::tuple{i, j, f}, std::tuple{j, i, -f}}) {
                if (given[a][b] && !(*given[a][b] == value))
                    fail(key, "contradicts an earlier bracket: {" + M.coordinates()[a] + "," + M.coordinates()[b] +
                                  "} was " + given[a][b]->to_string() + ", now " + value.to_string());
                given[a][b] = value;
            }
        }
        std::vector<std::vector<Poly>> pi(n, std::vector<Poly>(n, Poly(M.ring())));
        for (std::size_t a = 0; a < n; ++a)
            for (std::size_t b = 0; b < n; ++b)
                if (given[a][b]) pi[a][b] = *given[a][b];
        return PoissonStructure(M, std::move(pi));
    }

    std::pair<std::size_t, std::size_t> bracket_pair(const std::string& key, const std::string& text,
                                                     const PhaseSpace& M) const {
        auto comma = text.find(',');
        if (comma == std::string::npos) fail(key, "a bracket key is \"a,b\" with two coordinates");
        auto trim = [](std::string s) {
            s.erase(0, s.find_first_not_of(" \t"));
            s.erase(s.find_last_not_of(" \t") + 1);
            return s;
        };
        std::string a = trim(text.substr(0, comma)), b = trim(text.substr(comma + 1));
        long i = M.ring()->index_of(a), j = M.ring()->index_of(b);
        if (i < 0 || static_cast<std::size_t>(i) >= M.dim()) fail(key, "unknown coordinate '" + a + "'");
        if (j < 0 || static_cast<std::size_t>(j) >= M.dim()) fail(key, "unknown coordinate '" + b + "'");
        return {static_cast<std::size_t>(i), static_cast<std::size_t>(j)};
    }

    // A real number: a TOML integer or float, or a string holding a decimal or a rational "a/b".
    double real(const std::string& key, const toml::node& n, std::string* text = nullptr) const {
        if (n.is_integer() || n.is_floating_point()) {
            double v = *n.value<double>();
            if (!std::isfinite(v)) fail(key, "must be finite");
            if (text) *text = n.is_integer() ? std::to_string(*n.value<long>()) : Rational::from_double(v).to_string();
            return v;
        }
        if (n.is_string()) return real(key, *n.value<std::string>(), text);
        fail(key, "must be a number or a string holding a decimal or a rational like \"1/100\"");
    }
    double real(const std::string& key, const std::string& s, std::string* text = nullptr) const {
        try {
            double v = Rational::parse(s).to_double();
            if (!std::isfinite(v)) fail(key, "'" + s + "' is out of the double range");
            if (text) *text = s;
            return v;
        } catch (const std::invalid_argument& e) {
            fail(key, e.what());
        }
    }

    std::size_t order(const std::string& key, long k) const {
        if (k < 1) fail(key, "the order k must be at least 1, got " + std::to_string(k));
        if (k > 64) fail(key, "the order k must be at most 64, got " + std::to_string(k));
        return static_cast<std::size_t>(k);
    }

    void read_integrator(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "integrator", false);
        check_keys(t, "integrator", {"order", "dt", "realisation"});
        if (ov_.order) {
            try {
                std::size_t pos = 0;
                long k = std::stol(*ov_.order, &pos);
                if (pos != ov_.order->size()) throw std::invalid_argument("trailing characters");
                scene.order = order("--order", k);
            } catch (const std::logic_error&) {
                fail("--order", "'" + *ov_.order + "' is not an integer");
            }
        } else if (const toml::node* n = t.get("order")) {
            if (!n->is_integer()) fail("integrator.order", "must be an integer");
            scene.order = order("integrator.order", *n->value<long>());
        }
        if (ov_.dt) scene.dt = real("--dt", *ov_.dt, &scene.dt_text);
        else if (const toml::node* n = t.get("dt")) scene.dt = real("integrator.dt", *n, &scene.dt_text);
        if (!(scene.dt > 0)) fail(ov_.dt ? "--dt" : "integrator.dt", "the step dt must be positive, got " + scene.dt_text);
        std::optional<std::string> r = ov_.realisation ? ov_.realisation : string_at(t, "realisation", false, "integrator.");
        if (r) {
            try {
                scene.realisation = parse_realisation_choice(*r);
            } catch (const std::invalid_argument& e) {
                fail(ov_.realisation ? "--realisation" : "integrator.realisation", e.what());
            }
        }
        if (scene.realisation == RealisationChoice::closed_form && !has_closed_form(scene.pi.structure_class()))
            fail(ov_.realisation ? "--realisation" : "integrator.realisation",
                 "\"closed-form\" is not available for a general structure; use \"radial\" or \"auto\"");
    }

    void read_run(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "run", false);
        check_keys(t, "run", {"x0", "t_end"});
        const std::size_t n = scene.phase_space().dim();
        std::vector<double> x0;
        if (ov_.x0) {
            std::stringstream ss(*ov_.x0);
            std::string item;
            while (std::getline(ss, item, ',')) x0.push_back(real("--x0", item));
        } else if (const toml::node* node = t.get("x0")) {
            const toml::array* arr = node->as_array();
            if (!arr) fail("run.x0", "must be a list of numbers");
            for (std::size_t i = 0; i < arr->size(); ++i) x0.push_back(real("run.x0[" + std::to_string(i) + "]", (*arr)[i]));
        }
        if (ov_.x0 || t.get("x0")) {
            if (x0.size() != n)
                fail(ov_.x0 ? "--x0" : "run.x0", "has " + std::to_string(x0.size()) + " values for " + std::to_string(n) +
                                                     " coordinates");
            scene.x0 = std::move(x0);
        }
        if (ov_.t_end) scene.t_end = real("--t-end", *ov_.t_end);
        else if (const toml::node* node = t.get("t_end")) scene.t_end = real("run.t_end", *node);
        if (scene.t_end && !(*scene.t_end > 0)) fail(ov_.t_end ? "--t-end" : "run.t_end", "must be positive");
    }

    void read_magnus(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "magnus", false);
        check_keys(t, "magnus", {"h"});
        if (auto h = string_at(t, "h", false, "magnus.")) {
            try {
                scene.magnus_h = scene.phase_space().parse_in_time(*h);
            } catch (const ResourceLimitError& e) {
                throw ParseBudgetError(file_.string() + ": magnus.h: " + e.what());
            } catch (const std::exception& e) {
                fail("magnus.h", e.what());
            }
        }
    }

    std::filesystem::path file_;
    const SceneOverrides& ov_;
};

}  // namespace

Scene load_scene(const std::filesystem::path& file, const SceneOverrides& overrides) {
    return SceneReader(file, overrides).read();
}

Scene parse_scene(std::string_view text, const std::filesystem::path& file, const SceneOverrides& overrides) {
    return SceneReader(file, overrides).read_text(text);
}

void require_valid(const Scene& scene) {
    const auto& names = scene.phase_space().coordinates();
    if (auto f = scene.pi.jacobi_failure())
        throw SceneError(scene.file, "brackets",
                         "the Jacobi identity fails at (" + names[f->i] + ", " + names[f->j] + ", " + names[f->k] +
                             "): jacobiator = " + f->jacobiator.to_string());
    for (std::size_t c = 0; c < scene.casimirs.size(); ++c)
        if (auto f = scene.pi.casimir_failure(scene.casimirs[c]))
            throw SceneError(scene.file, "hamiltonian.casimirs[" + std::to_string(c) + "]",
                             "'" + scene.casimirs[c].to_string() + "' is not a Casimir: (pi grad C)_" + names[f->component] +
                                 " = " + f->value.to_string());
}

}  // namespace pgi
