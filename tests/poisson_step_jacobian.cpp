// The step's tangent map by the implicit function theorem (poisson/step_jacobian.hpp, docs/math.md 6): against
// central differences of the step on every bundled scene (each realisation form), a Poisson map's identities, other
// dt and the sparse path.
#include "poisson/step_jacobian.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <filesystem>

using namespace pgi;

namespace {

// Every scene of tools/scenes, by name.
std::vector<std::string> every_scene() {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(PGI_SCENES_DIR))
        if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    return names;
}

// The stepper's state: the scene's x0, then (where the scene has none, and for any coordinates past x0's) values in
// [1/2, 3/2], in every bundled scene's domain.
Eigen::VectorXd start(const Scene& s) {
    Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(Eigen::Index(s.phase_space().dim()), 0.5, 1.5);
    if (s.x0)
        x.head(Eigen::Index(s.x0->size())) =
            Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
    return x;
}

std::vector<double> point(const Scene& s, const Eigen::VectorXd& x) {
    return s.phase_space().point(std::span<const double>(x.data(), std::size_t(x.size())));
}

// pi(x), n x n.
Eigen::MatrixXd pi_at(const Scene& s, const Eigen::VectorXd& x) {
    const auto n = x.size();
    const std::vector<double> p = point(s, x);
    Eigen::MatrixXd P(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j) P(i, j) = evaluate(s.pi(std::size_t(i), std::size_t(j)), p);
    return P;
}

// grad C(x) as a row.
Eigen::RowVectorXd gradient(const Scene& s, const Poly& C, const Eigen::VectorXd& x) {
    const std::vector<double> p = point(s, x);
    Eigen::RowVectorXd g(x.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) g[i] = evaluate(derivative(C, std::size_t(i)), p);
    return g;
}

// d step / dx by central differences, h relative to |x|: truncation ~ h^2 |D^3 step|, round-off ~ u |x| / h.
Eigen::MatrixXd central_differences(NewtonStepper& st, const Eigen::VectorXd& x, double dt) {
    const Eigen::Index n = x.size();
    const double h = 1e-5 * std::max(1.0, x.lpNorm<Eigen::Infinity>());
    Eigen::MatrixXd fd(n, n);
    for (Eigen::Index j = 0; j < n; ++j) {
        Eigen::VectorXd e = Eigen::VectorXd::Zero(n), plus(n), minus(n);
        e[j] = h;
        REQUIRE(st.step(x + e, dt, plus) == StepStatus::ok);
        REQUIRE(st.step(x - e, dt, minus) == StepStatus::ok);
        fd.col(j) = ((x + e + plus) - (x - e + minus)) / (2 * h);
    }
    return fd;
}

}  // namespace

TEST_CASE("step_jacobian: equals central differences of the step on every bundled scene") {
    for (const std::string& name : every_scene()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x = start(s);
        NewtonStepper st = s.scheme->stepper(s.dt, x);
        CAPTURE(st.info().method);
        const StepWithJacobian j = step_with_jacobian(st, x, s.dt);
        REQUIRE(j.status == StepStatus::ok);
        const Eigen::MatrixXd fd = central_differences(st, x, s.dt);
        const double size = j.jacobian.lpNorm<Eigen::Infinity>();
        CAPTURE((j.jacobian - fd).lpNorm<Eigen::Infinity>() / size);
        CHECK((j.jacobian - fd).lpNorm<Eigen::Infinity>() <= 1e-7 * size);
        // and the step is not the identity: the comparison has something to compare
        CHECK((j.jacobian - Eigen::MatrixXd::Identity(x.size(), x.size())).lpNorm<Eigen::Infinity>() > 1e-4);
    }
}

TEST_CASE("step_jacobian: a Poisson map that keeps the Casimirs' gradients, on every bundled scene") {
    for (const std::string& name : every_scene()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        Eigen::VectorXd x = start(s);
        NewtonStepper st = s.scheme->stepper(s.dt, x);
        for (int n = 0; n < 10; ++n) {  // along a stretch of the orbit
            const StepWithJacobian j = step_with_jacobian(st, x, s.dt);
            REQUIRE(j.status == StepStatus::ok);
            // J pi(x) J^T = pi(step(x)), to round-off of the entries' sizes
            const Eigen::MatrixXd defect = j.jacobian * pi_at(s, x) * j.jacobian.transpose() - pi_at(s, j.x_new);
            const double scale =
                pi_at(s, x).lpNorm<Eigen::Infinity>() * std::pow(j.jacobian.lpNorm<Eigen::Infinity>(), 2);
            CAPTURE(defect.lpNorm<Eigen::Infinity>() / scale);
            CHECK(defect.lpNorm<Eigen::Infinity>() <= 1e-12 * scale);
            // grad C(step(x)) J = grad C(x)
            for (const Poly& C : s.casimirs) {
                const Eigen::RowVectorXd before = gradient(s, C, x);
                const Eigen::RowVectorXd kept = gradient(s, C, j.x_new) * j.jacobian;
                const double size = before.lpNorm<Eigen::Infinity>() * j.jacobian.lpNorm<Eigen::Infinity>();
                CAPTURE((kept - before).lpNorm<Eigen::Infinity>() / size);
                CHECK((kept - before).lpNorm<Eigen::Infinity>() <= 1e-12 * size);
            }
            x = j.x_new;
        }
    }
}

TEST_CASE("step_jacobian: at a dt other than the build's, as the step takes it") {
    const Scene s = test::bundled("rigid_body");
    const Eigen::VectorXd x = start(s);
    NewtonStepper st = s.scheme->stepper(s.dt, x);
    const double dt = s.dt / 3;
    const StepWithJacobian j = step_with_jacobian(st, x, dt);
    REQUIRE(j.status == StepStatus::ok);
    const Eigen::MatrixXd fd = central_differences(st, x, dt);
    CHECK((j.jacobian - fd).lpNorm<Eigen::Infinity>() <= 1e-7 * j.jacobian.lpNorm<Eigen::Infinity>());
}

TEST_CASE("step_jacobian: the sparse Newton path gives the dense path's Jacobian") {
    const Scene s = test::bundled("volterra_chain");
    const Eigen::VectorXd x = start(s);
    StepOptions dense, sparse;
    dense.k = sparse.k = s.scheme->order();
    dense.dt = sparse.dt = s.dt;
    dense.solver = NewtonSolverChoice::dense;
    sparse.solver = NewtonSolverChoice::sparse;
    NewtonStepper a = s.scheme->stepper(dense, x), b = s.scheme->stepper(sparse, x);
    REQUIRE(b.info().solver == NewtonSolver::sparse);
    const StepWithJacobian ja = step_with_jacobian(a, x, s.dt), jb = step_with_jacobian(b, x, s.dt);
    REQUIRE(ja.status == StepStatus::ok);
    REQUIRE(jb.status == StepStatus::ok);
    CHECK((ja.jacobian - jb.jacobian).lpNorm<Eigen::Infinity>() <= 1e-13 * ja.jacobian.lpNorm<Eigen::Infinity>());
}
