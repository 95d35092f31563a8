#pragma once
// The exact objects of a scheme read from plain strings (coordinate names, "a,b" -> bracket, polynomials),
// with errors that name the offending entry. Shared by the scene reader (scheme/scene.cpp) and the
// Scheme's constructor from values (the Python module's and the C++ consumers' entry point).
#include "poisson/structure.hpp"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pgi {

/// Bad input: key says where ("coordinates[2]", "brackets.\"x1,x2\"", "hamiltonian.H", ...), problem what;
/// what() reads "key: problem".
class InputError : public std::invalid_argument {
public:
    InputError(std::string key, std::string problem)
        : std::invalid_argument(key.empty() ? problem : key + ": " + problem), key_(std::move(key)),
          problem_(std::move(problem)) {}
    const std::string& key() const { return key_; }
    const std::string& problem() const { return problem_; }

private:
    std::string key_, problem_;
};

/// Checks coordinate names: non-empty, not the reserved 't', distinct, identifiers.
void check_coordinates(const std::vector<std::string>& names);
/// A polynomial in the coordinates of M; key names it in the error.
Poly parse_polynomial(const PhaseSpace& M, const std::string& key, const std::string& text);
/// pi from brackets {"a,b": "f"} (pi_ab = f, pi_ba = -f, every other entry 0). Throws InputError on a key
/// that is not two known coordinates, a non-zero {a,a}, or two entries that contradict each other.
PoissonStructure structure_from_brackets(const PhaseSpace& M,
                                         const std::vector<std::pair<std::string, std::string>>& brackets);
/// A parameter's default value (docs/user-guide.md, "Parameters"): "2", "-1/3" or a decimal read exactly ("0.05" is
/// 1/20). InputError(key) for anything else or a value beyond the double range.
Rational parse_parameter_value(const std::string& key, const std::string& text);
/// Checks parameter names: non-empty identifiers, not 't', distinct from each other and from the coordinates.
/// InputError("parameters.NAME").
void check_parameter_names(const std::vector<std::string>& coordinates, const std::vector<std::string>& parameters);
/// The order k: 1 <= k <= 64.
std::size_t check_order(const std::string& key, long k);

}  // namespace pgi
