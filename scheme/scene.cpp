#include "scheme/scene.hpp"

#include "scheme/input.hpp"
#include "scheme/detail/input_file.hpp"

#include <toml++/toml.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace pgi {

namespace {

// The deepest key a scene may write (a scene's own are three deep): toml++ reads, and its tables free, a dotted key
// by recursion, one level a segment, so that a key of 40000 segments (an 80 KB line) overflowed the stack.
constexpr std::size_t max_key_depth = 64;

// The line of the first key in text with more than max_key_depth segments, or 0. A lexical scan, before any parse:
// the dots outside strings and comments since the last of `= [ ] { } ,` or a line's end (a number or a date has one).
std::size_t deep_key_line(std::string_view text) {
    std::size_t line = 1, dots = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (c == '"' || c == '\'') {  // a string, basic or literal, on one line or several
            const std::string_view quote =
                text.substr(i, 3) == std::string(3, c) ? text.substr(i, 3) : text.substr(i, 1);
            std::size_t j = i + quote.size();
            while (j < text.size() && text.substr(j, quote.size()) != quote) {
                if (text[j] == '\\' && c == '"') ++j;  // an escape (the quote after it does not end the string)
                if (j < text.size() && text[j] == '\n') ++line;
                ++j;
            }
            i = std::min(text.size(), j + quote.size()) - 1;
        } else if (c == '#') {
            while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
        } else if (c == '.') {
            if (++dots >= max_key_depth) return line;  // (dots + 1 segments)
        } else if (c == '\n' || c == '=' || c == '[' || c == ']' || c == '{' || c == '}' || c == ',') {
            line += c == '\n';
            dots = 0;
        }
    }
    return 0;
}

// Reads one scene file; every error names the file and the key.
class SceneReader {
public:
    SceneReader(std::filesystem::path file, const SceneOverrides& overrides) : file_(std::move(file)), ov_(overrides) {}

    Scene read() { return read_text(file_text()); }

    Scene read_text(std::string_view text) {
        if (text.size() > max_scene_bytes)  // (a file's size is checked before it is read: read_input_file)
            fail("", "the text has " + std::to_string(text.size()) + " bytes, above the limit of " +
                         std::to_string(max_scene_bytes));
        toml::table doc = parse_document(text);
        check_keys(doc, "",
                   {"name", "coordinates", "parameters", "brackets", "hamiltonian", "integrator", "run", "magnus",
                    "splitting"});
        std::string name = string_at(doc, "name", true).value_or("");
        if (has_control(name)) fail("name", "contains a control character: '" + name + "'");
        std::vector<std::string> coordinates = read_coordinates(doc);
        std::vector<Parameter> parameters = read_parameters(doc, coordinates);
        for (const auto& p : parameters) coordinates.push_back(p.name);
        PhaseSpace M(coordinates, budget());
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
        Scene scene{file_,
                    name,
                    std::move(parameters),
                    std::move(pi),
                    std::move(H),
                    std::move(casimirs),
                    2,
                    0.1,
                    "1/10",
                    RealisationChoice::automatic,
                    NativePolicy::automatic,
                    {},
                    std::nullopt,
                    std::nullopt,
                    std::nullopt,
                    std::nullopt,
                    nullptr};
        read_integrator(doc, scene);
        read_parameter_values(scene);
        read_run(doc, scene);
        read_magnus(doc, scene);
        read_splitting(doc, scene);
        try {
            scene.scheme =
                std::make_shared<const Scheme>(scene.pi, scene.H, scene.casimirs, scene.order, scene.realisation,
                                               ov_.trust_jacobi, scene.jit, scene.parameters);
        } catch (const InputError& e) {  // a bracket that uses a parameter
            fail(e.key(), e.problem());
        }
        return scene;
    }

private:
    static bool has_control(const std::string& s) {
        return std::any_of(s.begin(), s.end(),
                           [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
    }

    [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
        throw SceneError(file_, key, problem);
    }

    // The input rules (scheme/detail/input_file.hpp), at most max_scene_bytes.
    std::string file_text() const {
        try {
            return read_input_file(file_, max_scene_bytes, "scene");
        } catch (const InputError& e) {
            fail("", e.problem());
        }
    }

    toml::table parse_document(std::string_view text) const {
        if (const std::size_t line = deep_key_line(text))
            fail("", "a key nested deeper than " + std::to_string(max_key_depth) + " levels at line " +
                         std::to_string(line));
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
        return std::make_shared<const Budget>(budget_limits(ov_.max_terms, ov_.max_memory_mb, ov_.max_seconds),
                                              ov_.progress);
    }

    Poly poly(const PhaseSpace& M, const std::string& key, const std::string& text) const {
        try {
            return parse_polynomial(M, key, text);
        } catch (const ResourceLimitError& e) {  // a budget refusal stays one (exit 4), naming the key
            throw ParseBudgetError(e.what());    // the key is in the message, pgi prefixes the file
        } catch (const InputError& e) {
            fail(e.key(), e.problem());
        }
    }

    std::vector<std::string> read_coordinates(const toml::table& doc) const {
        const toml::node* n = doc.get("coordinates");
        if (!n) fail("coordinates", "missing key");
        const toml::array* arr = n->as_array();
        if (!arr || arr->empty()) fail("coordinates", "must be a non-empty list of names");
        std::vector<std::string> names;
        std::set<std::string> seen;
        for (std::size_t i = 0; i < arr->size(); ++i) {
            std::string key = "coordinates[" + std::to_string(i) + "]";
            if (!(*arr)[i].is_string()) fail(key, "must be a string");
            std::string s = (*arr)[i].as_string()->get();
            if (s.empty()) fail(key, "empty coordinate name");
            if (has_control(s)) fail(key, "the coordinate name '" + s + "' contains a control character");
            if (s == "t") fail(key, "'t' is reserved for the time step");
            if (!seen.insert(s).second) fail(key, "duplicate coordinate '" + s + "'");
            names.push_back(std::move(s));
        }
        try {
            check_coordinates(names);
        } catch (const InputError& e) {
            fail(e.key(), e.problem());
        }
        return names;
    }

    // [parameters] name = "value": exact values (a string, or a TOML integer), sorted by name (as toml++ keeps them).
    std::vector<Parameter> read_parameters(const toml::table& doc, const std::vector<std::string>& coordinates) const {
        const toml::table& t = table_at(doc, "parameters", false);
        std::vector<Parameter> parameters;
        std::vector<std::string> names;
        try {
            for (const auto& [k, v] : t) {
                const std::string name(k.str()), key = "parameters." + name;
                if (has_control(name)) fail(key, "the parameter name contains a control character");
                std::string text;
                if (v.is_integer())
                    text = std::to_string(*v.value<long>());
                else if (v.is_string())
                    text = *v.value<std::string>();
                else
                    fail(key, "must be a string holding an exact value (\"2\", \"-1/3\", \"0.05\") or an integer");
                parameters.push_back({name, parse_parameter_value(key, text)});
                names.push_back(name);
            }
            check_parameter_names(coordinates, names);
        } catch (const InputError& e) {
            fail(e.key(), e.problem());
        }
        return parameters;
    }

    // The run's parameter values: the defaults, replaced by --param NAME=VALUE (a decimal or a rational a/b).
    void read_parameter_values(Scene& scene) const {
        for (const auto& p : scene.parameters) scene.parameter_values.push_back(p.value.to_double());
        for (const std::string& given : ov_.parameters) {
            const std::size_t eq = given.find('=');
            if (eq == std::string::npos) fail("--param", "'" + given + "' is not NAME=VALUE");
            const std::string name = given.substr(0, eq);
            const auto it = std::find_if(scene.parameters.begin(), scene.parameters.end(),
                                         [&](const Parameter& p) { return p.name == name; });
            if (it == scene.parameters.end()) {
                std::string known;
                for (const auto& p : scene.parameters) known += (known.empty() ? "" : ", ") + p.name;
                fail("--param", "unknown parameter '" + name + "' (the scene's parameters: " +
                                    (known.empty() ? std::string("none") : known) + ")");
            }
            scene.parameter_values[std::size_t(it - scene.parameters.begin())] =
                real("--param " + name, given.substr(eq + 1));
        }
    }

    PoissonStructure read_brackets(const toml::table& doc, const PhaseSpace& M) const {
        const toml::table& br = table_at(doc, "brackets", true);
        std::vector<std::pair<std::string, std::string>> brackets;
        for (const auto& [k, v] : br) {
            if (!v.is_string()) fail("brackets.\"" + std::string(k.str()) + "\"", "must be a polynomial string");
            brackets.emplace_back(std::string(k.str()), *v.value<std::string>());
        }
        try {
            return structure_from_brackets(M, brackets);
        } catch (const InputError& e) {
            fail(e.key(), e.problem());
        }
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
            const Rational exact = Rational::parse(s);
            const double v = exact.to_double();
            if (!std::isfinite(v)) fail(key, "'" + s + "' is out of the double range");
            if (v == 0 && !exact.is_zero()) fail(key, "'" + s + "' is below the double range (it rounds to 0)");
            if (text) *text = s;
            return v;
        } catch (const std::invalid_argument& e) {
            fail(key, e.what());
        }
    }

    std::size_t order(const std::string& key, long k) const {
        try {
            return check_order(key, k);
        } catch (const InputError& e) {
            fail(e.key(), e.problem());
        }
    }

    void read_integrator(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "integrator", false);
        check_keys(t, "integrator", {"order", "dt", "realisation", "jit"});
        if (const toml::node* n = t.get("jit")) {
            if (!n->is_boolean()) fail("integrator.jit", "must be true or false");
            scene.jit = *n->value<bool>() ? NativePolicy::always : NativePolicy::never;
        }
        if (ov_.jit) scene.jit = *ov_.jit;
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
        if (ov_.dt)
            scene.dt = real("--dt", *ov_.dt, &scene.dt_text);
        else if (const toml::node* n = t.get("dt"))
            scene.dt = real("integrator.dt", *n, &scene.dt_text);
        if (!(scene.dt > 0))
            fail(ov_.dt ? "--dt" : "integrator.dt", "the step dt must be positive, got " + scene.dt_text);
        std::optional<std::string> r =
            ov_.realisation ? ov_.realisation : string_at(t, "realisation", false, "integrator.");
        if (r) {
            try {
                scene.realisation = parse_realisation_choice(*r);
            } catch (const std::invalid_argument& e) {
                fail(ov_.realisation ? "--realisation" : "integrator.realisation", e.what());
            }
        }
        try {
            realisation_form(scene.pi.structure_class(), scene.realisation);
        } catch (const std::invalid_argument& e) {
            fail(ov_.realisation ? "--realisation" : "integrator.realisation", e.what());
        }
    }

    void read_run(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "run", false);
        check_keys(t, "run", {"x0", "t_end"});
        const std::size_t n = scene.dim();
        std::vector<double> x0;
        if (ov_.x0) {
            // strictly a,b,c: every item a number, no empty item (a trailing comma is an error)
            const std::string& list = *ov_.x0;
            std::size_t begin = 0;
            for (std::size_t i = 0;; ++i) {
                const std::size_t comma = std::min(list.find(',', begin), list.size());
                std::string item = list.substr(begin, comma - begin);
                item.erase(0, item.find_first_not_of(" \t"));
                item.erase(item.find_last_not_of(" \t") + 1);
                if (item.empty()) fail("--x0", "value " + std::to_string(i + 1) + " of '" + list + "' is empty");
                x0.push_back(real("--x0", item));
                if (comma == list.size()) break;
                begin = comma + 1;
            }
        } else if (const toml::node* node = t.get("x0")) {
            const toml::array* arr = node->as_array();
            if (!arr) fail("run.x0", "must be a list of numbers");
            for (std::size_t i = 0; i < arr->size(); ++i)
                x0.push_back(real("run.x0[" + std::to_string(i) + "]", (*arr)[i]));
        }
        if (ov_.x0 || t.get("x0")) {
            if (x0.size() != n)
                fail(ov_.x0 ? "--x0" : "run.x0",
                     "has " + std::to_string(x0.size()) + " values for " + std::to_string(n) + " coordinates");
            x0.insert(x0.end(), scene.parameter_values.begin(), scene.parameter_values.end());
            scene.x0 = std::move(x0);
        }
        if (ov_.t_end)
            scene.t_end = real("--t-end", *ov_.t_end);
        else if (const toml::node* node = t.get("t_end"))
            scene.t_end = real("run.t_end", *node);
        if (scene.t_end && !(*scene.t_end > 0)) fail(ov_.t_end ? "--t-end" : "run.t_end", "must be positive");
    }

    void read_magnus(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "magnus", false);
        check_keys(t, "magnus", {"h"});
        if (auto h = string_at(t, "h", false, "magnus.")) {
            try {
                scene.magnus_h = scene.phase_space().parse_in_time(*h);
            } catch (const ResourceLimitError& e) {
                throw ParseBudgetError(std::string("magnus.h: ") + e.what());
            } catch (const std::exception& e) {
                fail("magnus.h", e.what());
            }
        }
    }

    // [splitting] A: H = A + (H - A), both parts non-zero (a split with an empty part is no splitting)
    void read_splitting(const toml::table& doc, Scene& scene) const {
        const toml::table& t = table_at(doc, "splitting", false);
        check_keys(t, "splitting", {"A"});
        if (auto a = string_at(t, "A", false, "splitting.")) {
            Poly A = poly(scene.phase_space(), "splitting.A", *a);
            if (A.is_zero() || A == scene.H)
                fail("splitting.A", "must be a part of H other than 0 and H itself (B = H - A is the other part)");
            scene.splitting_A = std::move(A);
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
    try {
        scene.scheme->require_valid();
    } catch (const InputError& e) {
        throw SceneError(scene.file, e.key(), e.problem());
    }
}

}  // namespace pgi
