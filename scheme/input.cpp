#include "scheme/input.hpp"
#include "poisson/phase_space.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <tuple>

namespace pgi {

namespace {

std::string trim(std::string s) {
    s.erase(0, s.find_first_not_of(" \t"));
    s.erase(s.find_last_not_of(" \t") + 1);
    return s;
}

std::pair<std::size_t, std::size_t> bracket_pair(const std::string& key, const std::string& text, const PhaseSpace& M) {
    auto comma = text.find(',');
    if (comma == std::string::npos) throw InputError(key, "a bracket key is \"a,b\" with two coordinates");
    std::string a = trim(text.substr(0, comma)), b = trim(text.substr(comma + 1));
    long i = M.ring()->index_of(a), j = M.ring()->index_of(b);
    if (i < 0 || static_cast<std::size_t>(i) >= M.dim()) throw InputError(key, "unknown coordinate '" + a + "'");
    if (j < 0 || static_cast<std::size_t>(j) >= M.dim()) throw InputError(key, "unknown coordinate '" + b + "'");
    return {static_cast<std::size_t>(i), static_cast<std::size_t>(j)};
}

}  // namespace

void check_coordinates(const std::vector<std::string>& names) {
    if (names.empty()) throw InputError("coordinates", "must be a non-empty list of names");
    for (std::size_t i = 0; i < names.size(); ++i) {
        const std::string key = "coordinates[" + std::to_string(i) + "]";
        if (names[i].empty()) throw InputError(key, "empty coordinate name");
        if (names[i] == "t") throw InputError(key, "'t' is reserved for the time step");
        for (std::size_t j = 0; j < i; ++j)
            if (names[j] == names[i]) throw InputError(key, "duplicate coordinate '" + names[i] + "'");
    }
    try {
        PhaseSpace check(names);  // identifier syntax, and no coordinate named as another's momentum (p_x)
    } catch (const std::exception& e) {
        throw InputError("coordinates", e.what());
    }
}

Rational parse_parameter_value(const std::string& key, const std::string& text) {
    try {
        Rational r = Rational::parse(text);
        if (!std::isfinite(r.to_double())) throw InputError(key, "'" + text + "' is out of the double range");
        return r;
    } catch (const std::invalid_argument& e) {
        if (const auto* ie = dynamic_cast<const InputError*>(&e)) throw *ie;
        throw InputError(key, std::string(e.what()) + "; a parameter's value is exact: \"2\", \"-1/3\", \"0.05\"");
    }
}

void check_parameter_names(const std::vector<std::string>& coordinates, const std::vector<std::string>& parameters) {
    for (std::size_t i = 0; i < parameters.size(); ++i) {
        const std::string& name = parameters[i];
        const std::string key = "parameters." + name;
        if (name.empty()) throw InputError("parameters", "empty parameter name");
        if (name == "t") throw InputError(key, "'t' is reserved for the time step");
        if (std::find(coordinates.begin(), coordinates.end(), name) != coordinates.end())
            throw InputError(key, "'" + name + "' is also a coordinate");
        if (std::find(parameters.begin(), parameters.begin() + long(i), name) != parameters.begin() + long(i))
            throw InputError(key, "duplicate parameter '" + name + "'");
        try {
            Ring check(std::vector<std::string>{name});  // identifier syntax
        } catch (const std::exception& e) {
            throw InputError(key, e.what());
        }
    }
}

Poly parse_polynomial(const PhaseSpace& M, const std::string& key, const std::string& text) {
    try {
        return M.parse(text);
    } catch (const ResourceLimitError& e) {  // a budget refusal stays one (exit 4), naming the key
        throw ParseBudgetError(key + ": " + e.what());
    } catch (const std::exception& e) {
        throw InputError(key, e.what());
    }
}

PoissonStructure structure_from_brackets(const PhaseSpace& M,
                                         const std::vector<std::pair<std::string, std::string>>& brackets) {
    std::map<std::pair<std::size_t, std::size_t>, Poly> given;  // only the pairs given: no n x n
    for (const auto& [k, v] : brackets) {
        const std::string key = "brackets.\"" + k + "\"";
        auto [i, j] = bracket_pair(key, k, M);
        Poly f = parse_polynomial(M, key, v);
        if (i == j) {
            if (!f.is_zero())
                throw InputError(key, "not skew: {" + M.coordinates()[i] + "," + M.coordinates()[i] + "} must be 0");
            continue;
        }
        // {a,b} given as f means pi_ab = f and pi_ba = -f
        for (auto [a, b, value] : {std::tuple{i, j, f}, std::tuple{j, i, -f}}) {
            const auto it = given.find({a, b});
            if (it != given.end() && !(it->second == value))
                throw InputError(key, "contradicts an earlier bracket: {" + M.coordinates()[a] + "," +
                                          M.coordinates()[b] + "} was " + it->second.to_string() + ", now " +
                                          value.to_string());
            given.insert_or_assign({a, b}, value);
        }
    }
    return PoissonStructure(M, std::move(given));
}

std::size_t check_order(const std::string& key, long k) {
    if (k < 1) throw InputError(key, "the order k must be at least 1, got " + std::to_string(k));
    if (k > 64) throw InputError(key, "the order k must be at most 64, got " + std::to_string(k));
    return static_cast<std::size_t>(k);
}

}  // namespace pgi
