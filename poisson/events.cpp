#include "poisson/events.hpp"

#include "poisson/detail/root_bracket.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace pgi {

EventSet EventSet::build(const PhaseSpace& M, std::vector<EventSpec> specs, const EventNaming& naming) {
    EventSet s;
    s.dim_ = M.dim();
    std::vector<Poly> g, grad;
    for (std::size_t i = 0; i < specs.size(); ++i) {
        const std::string name = naming(i);
        if (specs[i].direction < -1 || specs[i].direction > 1)
            throw std::invalid_argument(name + ": direction " + std::to_string(specs[i].direction) +
                                        " is not -1, 0 or 1");
        try {
            g.push_back(M.parse(specs[i].polynomial));
        } catch (const ParseError& e) {
            throw ParseError(name + ": " + e.what());
        }
        if (g.back().total_degree() < 1)
            throw std::invalid_argument(name + ": '" + specs[i].polynomial + "' is constant, it never crosses zero");
        for (std::size_t l = 0; l < M.dim(); ++l) grad.push_back(derivative(g.back(), M.x(l)));
    }
    s.g_ = CompiledMap::build(g, M.coordinate_vars());
    s.grad_ = CompiledMap::build(grad, M.coordinate_vars());
    s.specs_ = std::move(specs);
    return s;
}

bool EventSet::crosses(std::size_t i, double g0, double g1) const {
    const int d = specs_[i].direction;
    const bool up = g0 < 0 && g1 >= 0, down = g0 > 0 && g1 <= 0;
    return d > 0 ? up : d < 0 ? down : up || down;
}

EventDetector::EventDetector(EventSet events, DenseOutput dense, std::size_t samples)
    : events_(std::move(events)), dense_(std::move(dense)), samples_(std::max<std::size_t>(1, samples)) {
    if (dense_.dim() != events_.dim())
        throw std::invalid_argument("EventDetector: the dense output has dimension " + std::to_string(dense_.dim()) +
                                    ", the events " + std::to_string(events_.dim()));
    const auto n = Eigen::Index(events_.dim()), m = Eigen::Index(events_.size());
    g0_ = g1_ = ga_ = gb_ = Eigen::VectorXd::Zero(m);
    y_ = dy_ = Eigen::VectorXd::Zero(n);
    grad_ = Eigen::VectorXd::Zero(n * m);
    all_ = Eigen::VectorXd::Zero(m);
}

void EventDetector::start(const Eigen::VectorXd& x0) {
    events_.values(x0.data(), g0_.data());
}

double EventDetector::locate(std::size_t event, double a, double b, double ga, double gb) {
    const auto n = Eigen::Index(events_.dim());
    auto g_and_derivative = [&](double theta) {
        dense_.eval(theta, y_.data());
        dense_.eval_derivative(theta, dy_.data());
        events_.values(y_.data(), all_.data());
        events_.gradients(y_.data(), grad_.data());
        const double dg = grad_.segment(Eigen::Index(event) * n, n).dot(dy_);
        return std::pair<double, double>{all_(Eigen::Index(event)), dg};
    };
    return find_root(g_and_derivative, a, b, ga, gb);
}

// Solves g(x0 + step(x0, theta dt)) = 0 for theta from the dense output's root, by the secant method started with the
// dense output's dg/dtheta there (which the partial step's derivative in theta matches to the method's order): stops
// once theta moves by less than 4 u, after at most eight partial steps; c takes the last partial step's state and
// time (the dense output's stay where a partial step fails).
void EventDetector::on_leaf(Crossing& c, const Eigen::VectorXd& x0, double t0, double dt, double theta) {
    const auto n = Eigen::Index(events_.dim()), e = Eigen::Index(c.event);
    dense_.eval_derivative(theta, dy_.data());
    events_.gradients(c.x.data(), grad_.data());
    double slope = grad_.segment(e * n, n).dot(dy_), previous_theta = 0, previous_g = 0;
    for (int round = 0; round < 8 && theta > 0 && std::abs(slope) > 0 && std::isfinite(slope); ++round) {
        if (stepper_->step(x0, theta * dt, increment_) != StepStatus::ok) return;
        y_ = x0 + increment_;
        if (!y_.allFinite()) return;
        c.x = y_, c.t = t0 + theta * dt;
        events_.values(y_.data(), all_.data());
        const double g = all_(e);
        if (round > 0 && theta != previous_theta && g != previous_g)
            slope = (g - previous_g) / (theta - previous_theta);
        const double move = g / slope;
        if (!(std::abs(move) > 4 * std::numeric_limits<double>::epsilon())) return;
        previous_theta = theta, previous_g = g;
        theta = std::clamp(theta - move, 0.0, 1.0);
    }
}

const std::vector<Crossing>& EventDetector::advance(const Eigen::VectorXd& x0, const Eigen::VectorXd& x1, double t0,
                                                    double dt, std::size_t step) {
    found_.clear();
    events_.values(x1.data(), g1_.data());
    bool fitted = false;
    auto fit = [&] {
        if (!fitted) dense_.fit(x0, x1, dt);
        fitted = true;
    };
    gb_ = g0_;
    for (std::size_t s = 1; s <= samples_; ++s) {
        const double a = double(s - 1) / double(samples_), b = double(s) / double(samples_);
        ga_ = gb_;
        if (s == samples_)
            gb_ = g1_;
        else {
            fit();
            dense_.eval(b, y_.data());
            events_.values(y_.data(), gb_.data());
        }
        for (std::size_t i = 0; i < events_.size(); ++i) {
            const auto e = Eigen::Index(i);
            if (!events_.crosses(i, ga_(e), gb_(e))) continue;
            fit();
            const double theta = locate(i, a, b, ga_(e), gb_(e));
            Crossing c;
            c.event = i;
            c.step = step;
            c.t = t0 + theta * dt;
            c.x = Eigen::VectorXd(x0.size());
            dense_.eval(theta, c.x.data());
            if (stepper_) on_leaf(c, x0, t0, dt, theta);
            found_.push_back(std::move(c));
        }
    }
    std::stable_sort(found_.begin(), found_.end(), [](const Crossing& p, const Crossing& q) { return p.t < q.t; });
    auto terminal =
        std::find_if(found_.begin(), found_.end(), [&](const Crossing& c) { return events_.spec(c.event).terminal; });
    if (terminal != found_.end()) found_.erase(terminal + 1, found_.end());
    g0_ = g1_;
    return found_;
}

}  // namespace pgi
