#include "poisson/detail/truncation_degree.hpp"

#include "poisson/hamilton_jacobi.hpp"
#include "poisson/detail/newton_rules.hpp"
#include "poisson/predictor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pgi {

namespace {

std::vector<double> phase_point(const Eigen::VectorXd& x, const Eigen::VectorXd& p) {
    std::vector<double> point(x.data(), x.data() + x.size());
    point.insert(point.end(), p.data(), p.data() + p.size());
    return point;
}

// The sizes of A_m's terms at point, max over the components, / scale, for m = 0..D (exact coefficients: build
// time only).
std::vector<double> component_sizes(const Realisation& r, const std::vector<double>& point, double scale) {
    std::vector<double> a(r.degree + 1, 0.0);
    for (std::size_t m = 0; m <= r.degree; ++m)
        for (const auto& s : r.alpha) a[m] = std::max(a[m], term_size(s[m], point) / scale);
    return a;
}

// The geometric decay of the sizes a[m] (component_sizes) measured through the probe's degree, fitted on the last
// four non-zero ones, extrapolated past it: a[last] rho^(m - last); infinite while no decay is seen, zero
// once the series has ended (two measured degrees past the last non-zero one).
class Decay {
public:
    explicit Decay(const std::vector<double>& a) {
        std::vector<std::size_t> nz;
        for (std::size_t m = 1; m < a.size(); ++m)
            if (a[m] > 0) nz.push_back(m);
        if (nz.empty() || a.size() - 1 >= nz.back() + 2) return;  // ended
        last_ = nz.back(), size_ = a[last_];
        const std::size_t lo = nz[nz.size() >= 4 ? nz.size() - 4 : 0];
        rho_ = lo < last_ ? std::pow(size_ / a[lo], 1.0 / double(last_ - lo)) : 1.0;
    }
    double at(std::size_t m) const {
        if (size_ == 0) return 0;
        return rho_ >= 1 ? std::numeric_limits<double>::infinity() : size_ * std::pow(rho_, double(m - last_));
    }
    // the first degree past `from` whose extrapolated size is at most target (from + 1 if none is known)
    std::size_t reaching(double target, std::size_t from) const {
        if (size_ == 0 || rho_ >= 1) return from + 1;
        const double steps = std::ceil(std::log(target / size_) / std::log(rho_));
        return std::max(from + 1, last_ + static_cast<std::size_t>(std::max(0.0, steps)));
    }

private:
    std::size_t last_ = 0;
    double size_ = 0, rho_ = 0;
};

// Symmetric realisations of some structures (constant, linear) have vanishing odd parts: then one measured
// neglected degree can be an identically zero one, and two are needed.
bool has_parity_gaps(const std::vector<double>& a) {
    for (std::size_t m = 1; m + 1 < a.size(); ++m)
        if (a[m] == 0 && *std::max_element(a.begin() + std::ptrdiff_t(m) + 1, a.end()) > 0) return true;
    return false;
}

// The smallest D >= D_min whose neglected terms are below round-off at the typical state: the measured ones
// (one degree at least past D, two where parity gaps appear) and the fitted decay's next two beyond the probe.
// Deepens the probe to where the fitted decay says D lies, one degree past it, until found or the cap.
// Sets truncation to the largest neglected size (measured or extrapolated): at the cap it may be large.
std::size_t choose_degree(const StepOptions& opt, std::size_t D_min, RealisationPtr& probe,
                          const RealisationSource& source, const std::vector<double>& point, double scale,
                          double& truncation) {
    const double target = unit_roundoff / 4;
    for (;;) {
        const auto a = component_sizes(*probe, point, scale);
        const Decay decay(a);
        const std::size_t top = probe->degree, need = has_parity_gaps(a) ? 2 : 1;
        const auto tail = [&](std::size_t d) {
            return std::max(
                {*std::max_element(a.begin() + std::ptrdiff_t(d) + 1, a.end()), decay.at(top + 1), decay.at(top + 2)});
        };
        for (std::size_t d = D_min; d + need <= top; ++d)
            if (tail(d) <= target || d == opt.max_degree) {
                truncation = tail(d);
                return d;
            }
        const std::size_t next = std::min(decay.reaching(target, top) - 1 + need, opt.max_degree + need);
        probe = source(std::max(next, top + 1));
    }
}

// The realisation's parts of degrees D + 1 and D + 2 (what exists of them in the probe), for the step's
// truncation check at the solution.
std::vector<Poly> neglected_parts(const Realisation& probe, std::size_t D) {
    std::vector<Poly> parts;
    for (std::size_t m = D + 1; m <= std::min(D + 2, probe.degree); ++m)
        for (const auto& a : probe.alpha) parts.push_back(a[m]);
    return parts;
}

}  // namespace

std::size_t step_degree_min(std::size_t k) {
    return std::max<std::size_t>(realisation_degree_for_order(k), 1);
}

std::size_t probe_degree(RealisationForm form, const StepOptions& opt, std::size_t n) {
    const std::size_t D_min = step_degree_min(opt.k);
    if (form == RealisationForm::radial)
        return std::max(D_min + 2, opt.predictor_order);  // two measured degrees to fit
    // the constant form's degree is chosen by choose_degree too (two measured degrees past D); the others
    // are evaluated in closed form and the probe serves the predictor only (its first pass on a lattice)
    const std::size_t predictor = n < shallow_probe_from ? predictor_limit(opt) : predictor_first_pass(opt);
    return std::max(D_min, predictor) + (form == RealisationForm::constant ? 2 : 0);
}

StepRealisation step_realisation(const PoissonStructure& pi, const StepOptions& opt, RealisationPtr& probe,
                                 const RealisationSource& source, double scale, const Eigen::VectorXd& p0,
                                 const SizePoint& sizes) {
    const RealisationForm form = realisation_form(pi.structure_class(), opt.realisation);
    const std::size_t D_min = step_degree_min(opt.k);
    if (form == RealisationForm::log_canonical)
        return {RealisationEvaluator::log_canonical(pi), probe->method + " (closed form)", 0, true, 0.0};
    if (form == RealisationForm::lie_poisson && RealisationEvaluator::has_rotation_form(pi))
        return {RealisationEvaluator::rotation(pi), probe->method + " (closed form, so(3))", 0, true, 0.0};
    if (form == RealisationForm::lie_poisson) {
        // |L| may grow along the orbit and during Newton: a margin of 1.5 before scaling and squaring takes over
        const double norm = RealisationEvaluator::lie_poisson(pi, 0).operator_norm_at(p0);
        const std::size_t D =
            RealisationEvaluator::series_degree_for(1.5 * norm, std::max<std::size_t>(D_min, 2), opt.max_degree);
        return {RealisationEvaluator::lie_poisson(pi, D),
                probe->method + " (series, scaling and squaring beyond)",
                D,
                true,
                0.0,
                false};
    }
    StepRealisation r;
    r.degree = choose_degree(opt, D_min, probe, source, phase_point(sizes.x, sizes.p), scale, r.truncation_estimate);
    r.method = probe->method;
    r.exact = form == RealisationForm::constant;
    r.evaluator = RealisationEvaluator::polynomial(pi, truncated(*probe, r.degree), neglected_parts(*probe, r.degree));
    return r;
}

}  // namespace pgi
