#pragma once
// Bi-realisations (alpha, beta) of pi on T*R^n as series in the momenta (docs/math.md sections 2-4).
#include "poisson/structure.hpp"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pgi {

/// How to build the realisation: a closed form where the class has one, the radial recursion, or
/// the closed form if there is one and the radial recursion otherwise.
enum class RealisationChoice { automatic, closed_form, radial };
RealisationChoice parse_realisation_choice(std::string_view text);  // "auto" | "closed-form" | "radial"
std::string to_string(RealisationChoice c);

/// alpha_i and beta_i as series graded by p-degree, truncated after degree D (order D + 1).
struct Realisation {
    std::string method;         // "constant", "lie-poisson", "log-canonical" or "radial"
    std::size_t degree;         // D
    std::vector<Series> alpha;  // alpha[i][m]: the part of alpha_i of degree m in p
    std::vector<Series> beta;
};

/// Whether a closed form (docs/math.md section 3) exists for this class.
bool has_closed_form(StructureClass c);

/// The form a realisation takes: one of the closed forms of docs/math.md section 3, or the radial recursion
/// of section 4. realisation_form() is the one place that decides it from the class and the choice.
enum class RealisationForm { constant, lie_poisson, log_canonical, radial };
/// "constant", "lie-poisson", "log-canonical", "radial" (Realisation::method).
std::string to_string(RealisationForm f);
/// The closed form of the class unless the choice is radial or the class has none (then radial).
/// Throws std::invalid_argument for closed_form on a general structure.
RealisationForm realisation_form(StructureClass c, RealisationChoice choice);
/// Set the result to the realisation of pi truncated at p-degree D, built as choice says.
/// Requires: pi satisfies the Jacobi identity. Throws std::invalid_argument for closed_form on a general pi.
Realisation build_realisation(const PoissonStructure& pi, RealisationChoice choice, std::size_t D);
/// docs/math.md section 3: alpha = x - (1/2) pi p.
Realisation constant_realisation(const PoissonStructure& pi, std::size_t D);
/// docs/math.md section 3: alpha = g(L(p)) x, g(z) = z/(e^z - 1) = sum B_m z^m / m!, L(p) x = pi(x) p.
Realisation lie_poisson_realisation(const PoissonStructure& pi, std::size_t D);
/// docs/math.md section 3: alpha_j = exp((1/2) sum_i a_ij x_i p_i) x_j.
Realisation log_canonical_realisation(const PoissonStructure& pi, std::size_t D);
/// docs/math.md section 4: the radial recursion, for any polynomial Poisson structure.
Realisation radial_realisation(const PoissonStructure& pi, std::size_t D);

/// The same realisation through p-degree D <= r.degree (its parts of degree above D dropped).
Realisation truncated(const Realisation& r, std::size_t D);

/// Whether beta(x, p) = alpha(x, -p) exactly, through r.degree: every realisation built here is (docs/math.md 4-5:
/// then S_2 = S_4 = ... = 0). Checked on the polynomials, not read from r.method: a Realisation is open to its user.
bool is_symmetric(const Realisation& r);

/// A realisation shared, not copied: on a lattice of n sites alpha and beta hold O(n) series, and the step's build
/// reads the Scheme's one several times.
using RealisationPtr = std::shared_ptr<const Realisation>;
/// The realisation through p-degree D, exact. The Scheme binds it to its own (DeepestRealisation).
using RealisationSource = std::function<RealisationPtr(std::size_t)>;

/// One realisation of pi at the deepest p-degree asked so far: a request beyond it builds it again (to
/// max(D, build_at_least), for a caller that knows it will soon ask deeper), one at its degree shares it, one below
/// gets a truncated copy. The rule of the Scheme and of NewtonStepper::build(pi, H, ...); not locked (its owner is).
class DeepestRealisation {
public:
    explicit DeepestRealisation(RealisationChoice choice) : choice_(choice) {}
    RealisationPtr through(const PoissonStructure& pi, std::size_t D, std::size_t build_at_least = 0);
    /// The deepest built so far (null before the first request).
    const RealisationPtr& deepest() const { return deepest_; }
    std::size_t builds() const { return builds_; }

private:
    RealisationChoice choice_;
    RealisationPtr deepest_;
    std::size_t builds_ = 0;
};

/// The canonical bracket of two p-graded series, truncated one degree lower (order N - 1).
Series canonical_bracket(const PhaseSpace& M, const Series& F, const Series& G);

/// A realisation identity of docs/math.md section 2 that fails below degree D: which one, where, and the defect.
struct RealisationDefect {
    std::string identity;  // "{alpha_i, alpha_j} = pi_ij(alpha)", ...
    std::size_t i, j;
    std::size_t degree;  // p-degree of the first non-zero part of the defect
    Poly defect;
};
/// Checks {alpha_i, alpha_j} = pi_ij(alpha), {beta_i, beta_j} = -pi_ij(beta), {alpha_i, beta_j} = 0
/// exactly in every p-degree below D. Returns the first failure, if any.
std::optional<RealisationDefect> realisation_defect(const PoissonStructure& pi, const Realisation& r);

}  // namespace pgi
