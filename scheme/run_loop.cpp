#include "scheme/run_loop.hpp"

#include <cmath>
#include <cstdio>

namespace pgi {

namespace {

std::string numbered(char letter, std::size_t i) {
    std::string name(1, letter);  // (not letter + std::to_string(i): GCC 12 warns of a false -Wrestrict there)
    name += std::to_string(i);
    return name;
}

std::vector<std::string> invariant_names(const Scheme& scheme, std::size_t extra,
                                         std::vector<std::string> extra_names) {
    std::vector<std::string> names{"H"};
    for (std::size_t c = 1; c <= scheme.casimirs().size(); ++c) names.push_back(numbered('C', c));
    for (std::size_t e = 0; e < extra; ++e)
        names.push_back(e < extra_names.size() ? std::move(extra_names[e]) : numbered('I', e + 1));
    return names;
}

// How fmt prints a double that is not finite: "inf", "-inf", "nan", "-nan".
std::string non_finite_text(double v) {
    return std::string(std::signbit(v) ? "-" : "") + (std::isnan(v) ? "nan" : "inf");
}

}  // namespace

RunLoop::RunLoop(const Scheme& scheme, std::vector<Poly> extra, std::vector<std::string> extra_names)
    : scheme_(&scheme), extra_(std::move(extra)), invariants_(scheme.invariants(extra_)),
      names_(invariant_names(scheme, extra_.size(), std::move(extra_names))), values_(invariants_.num_outputs()),
      initial_(values_), worst_(values_), scale_(values_) {}

void RunLoop::start(const Eigen::VectorXd& x0) {
    scale_ = invariant_scales(*scheme_, std::span<const double>(x0.data(), std::size_t(x0.size())), extra_);
    std::fill(worst_.begin(), worst_.end(), 0.0);
    fit_count_ = fit_n_ = fit_nn_ = 0;
    fit_e_.assign(values_.size(), 0.0);
    fit_ne_.assign(values_.size(), 0.0);
    non_finite_.clear();
    last_ = x0;
}

bool RunLoop::evaluate(const Eigen::VectorXd& x) {
    invariants_.eval(x.data(), values_.data());
    return all_finite();
}

bool RunLoop::all_finite() {
    for (std::size_t i = 0; i < values_.size(); ++i)
        if (!std::isfinite(values_[i])) {
            non_finite_ = names_[i] + " = " + non_finite_text(values_[i]);
            return false;
        }
    return true;
}

void RunLoop::commit(bool first) {
    if (cancel_) cancel_->check();
    if (first) initial_ = values_;
    for (std::size_t i = 0; i < values_.size(); ++i) worst_[i] = std::max(worst_[i], error(i));
    const double n = fit_count_;
    fit_count_ += 1, fit_n_ += n, fit_nn_ += n * n;
    for (std::size_t i = 0; i < values_.size(); ++i) {
        const double e = scale_[i] > 0 ? (values_[i] - initial_[i]) / scale_[i] : values_[i] - initial_[i];
        fit_e_[i] += e, fit_ne_[i] += n * e;
    }
}

std::vector<double> RunLoop::drift_per_step() const {
    std::vector<double> slope(fit_e_.size(), 0.0);
    const double d = fit_count_ * fit_nn_ - fit_n_ * fit_n_;
    if (d > 0)
        for (std::size_t i = 0; i < slope.size(); ++i) slope[i] = (fit_count_ * fit_ne_[i] - fit_n_ * fit_e_[i]) / d;
    return slope;
}

std::string RunLoop::failure_message(const NewtonStepper& stepper, const RunEnd& end) const {
    if (end.non_finite.empty()) return step_failure_message(stepper, end.steps + 1, end.status);
    if (!end.started) return "the invariant " + end.non_finite + " at x0 is not finite: nothing to integrate";
    char buffer[512];
    std::snprintf(buffer, sizeof buffer,
                  "step %zu (from t = %.17g) failed: non-finite invariant %s after the step; a smaller dt may help",
                  end.steps + 1, double(end.steps) * stepper.dt(), end.non_finite.c_str());
    return buffer;
}

}  // namespace pgi
