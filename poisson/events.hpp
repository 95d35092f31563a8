#pragma once
// Events: polynomials g(x) whose zeros the integration reports, located to round-off on the dense
// output of the step that crosses them (Poincare sections are the crossings of one event).
#include "poisson/dense_output.hpp"
#include "poisson/integrate.hpp"

#include <optional>
#include <string>
#include <vector>

namespace pgi {

struct EventSpec {
    std::string polynomial;  // g, in the coordinates
    int direction = 0;       // +1: g crosses upward (from < 0 to >= 0), -1: downward, 0: both
    bool terminal = false;   // the integration stops at its first crossing
};

/// How errors name event i: prefix, i + first, suffix ("event 2" on the command line, "events[1]" in Python).
struct EventNaming {
    std::string prefix = "event ";
    std::size_t first = 1;
    std::string suffix;
    std::string operator()(std::size_t i) const { return prefix + std::to_string(i + first) + suffix; }
};

/// The event functions compiled with their gradients.
class EventSet {
public:
    EventSet() = default;
    /// Throws ParseError "event I: malformed polynomial ..." (I from 1, or as naming says) for a polynomial
    /// the parser refuses (unknown variable, syntax, ...: the parser's message gives the position),
    /// std::invalid_argument for a constant g or a direction other than -1, 0, 1.
    static EventSet build(const PhaseSpace& M, std::vector<EventSpec> specs, const EventNaming& naming = {});

    std::size_t size() const { return specs_.size(); }
    std::size_t dim() const { return dim_; }
    const EventSpec& spec(std::size_t i) const { return specs_[i]; }
    /// g[i] = g_i(x) for every event.
    void values(const double* x, double* g) const { g_.eval(x, g); }
    /// grad[i n + l] = d g_i / d x_l.
    void gradients(const double* x, double* grad) const { grad_.eval(x, grad); }
    /// Whether g_i going from g0 to g1 is a crossing in event i's direction (a zero is reached from
    /// the side the direction names; a start on the zero is not a crossing, it was reported before).
    bool crosses(std::size_t i, double g0, double g1) const;
    /// Its compiled maps (g and its gradients), for code to be attached to.
    std::vector<CompiledMap*> compiled_maps() { return {&g_, &grad_}; }

private:
    std::vector<EventSpec> specs_;
    std::size_t dim_ = 0;
    CompiledMap g_, grad_;
};

struct Crossing {
    std::size_t event = 0;  // index in the EventSet
    std::size_t step = 0;   // the step n (from t_{n-1} to t_n) it lies in
    double t = 0;
    Eigen::VectorXd x;  // the state at t: a partial step's (step_crossings), else the dense output's
};

/// Finds the crossings of each step on its dense output. Checks the sign of every g at the ends of
/// the step and, with samples > 1, at samples - 1 interior points of the dense output (a pair of
/// crossings of one event within one sub-interval cancels and is not seen, as with any sign test).
class EventDetector {
public:
    EventDetector(EventSet events, DenseOutput dense, std::size_t samples = 1);

    /// The state the run starts from (its g values are the first step's left ends).
    void start(const Eigen::VectorXd& x0);
    /// From now on each crossing's state is a true partial step of (a copy of) stepper from the step's start, of the
    /// size that puts it on g = 0 (Newton on theta from the dense output's root, the dense output's dg/dtheta), so it
    /// keeps the Casimirs as every step does; the dense output's state stays where a partial step fails.
    void step_crossings(const NewtonStepper& stepper) { stepper_.emplace(stepper); }
    /// The crossings of the step x0 -> x1 (t0 to t0 + dt, step number `step`), in time order, cut
    /// after the first terminal one. x0 must be the previous call's x1 (or start()'s x0).
    const std::vector<Crossing>& advance(const Eigen::VectorXd& x0, const Eigen::VectorXd& x1, double t0, double dt,
                                         std::size_t step);
    const EventSet& events() const { return events_; }

private:
    double locate(std::size_t event, double a, double b, double ga, double gb);
    void on_leaf(Crossing& c, const Eigen::VectorXd& x0, double t0, double dt, double theta);

    EventSet events_;
    DenseOutput dense_;
    std::size_t samples_;
    Eigen::VectorXd g0_, g1_, ga_, gb_, y_, dy_, grad_, all_;  // all_: g at the root finder's iterate
    std::optional<NewtonStepper> stepper_;                     // step_crossings' copy, for the partial steps
    Eigen::VectorXd increment_;
    std::vector<Crossing> found_;
};

/// The event work of step n (x_previous -> x_n, of size dt) inside a run's observer: its crossings passed
/// to on_crossing(const Crossing&) in time order (and counted); the first that stops the run (on_crossing
/// returned true, or its event is terminal) is returned, nullptr when none does.
template <class OnCrossing>
const Crossing* report_crossings(EventDetector& detector, const Eigen::VectorXd& x_previous, const Eigen::VectorXd& x_n,
                                 double dt, std::size_t n, std::size_t& count, OnCrossing&& on_crossing) {
    for (const Crossing& c : detector.advance(x_previous, x_n, double(n - 1) * dt, dt, n)) {
        ++count;
        if (on_crossing(c) || detector.events().spec(c.event).terminal) return &c;
    }
    return nullptr;
}

}  // namespace pgi
