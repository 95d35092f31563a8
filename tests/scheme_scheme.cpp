// The Scheme: each artefact equals the free functions' result exactly, whatever was asked before it.
#include "magnus/modified_hamiltonian.hpp"
#include "poisson/hamilton_jacobi.hpp"
#include "scheme/scheme.hpp"
#include "scheme/trajectory.hpp"
#include "test_util.hpp"
#include "tools/commands.hpp"

#include <doctest/doctest.h>
#include <atomic>
#include <chrono>
#include <thread>

using namespace pgi;

namespace {

bool same(const Realisation& a, const Realisation& b) {
    if (a.method != b.method || a.degree != b.degree || a.alpha.size() != b.alpha.size()) return false;
    for (std::size_t i = 0; i < a.alpha.size(); ++i)
        for (std::size_t m = 0; m <= a.degree; ++m)
            if (!(a.alpha[i][m] == b.alpha[i][m]) || !(a.beta[i][m] == b.beta[i][m])) return false;
    return true;
}

Eigen::VectorXd vec(const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

}  // namespace

TEST_CASE("Scheme: a realisation truncated from a deeper one equals the one built at that degree") {
    for (const auto& name : test::bundled_names()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Scheme& scheme = *s.scheme;
        scheme.realisation(4);  // the deepest so far: degree 2 is cut from it
        CHECK(same(scheme.realisation(2), build_realisation(s.pi, s.realisation, 2)));
        CHECK(same(scheme.realisation(4), build_realisation(s.pi, s.realisation, 4)));
    }
}

TEST_CASE("Scheme: S_1..S_k and H_0..H_m equal the free functions', in either order of asking") {
    for (const auto& name : test::bundled_names()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const std::size_t k = s.order;
        const auto S = hamilton_jacobi_terms(
            s.phase_space(), build_realisation(s.pi, s.realisation, realisation_degree_for_order(k)), s.H, k);
        const auto Ht = modified_hamiltonian(s.pi, s.H, k, s.realisation, 3);
        Scheme terms_first = *s.scheme, modified_first = *s.scheme;  // copies start empty
        CHECK(terms_first.terms() == S);
        CHECK(terms_first.modified_hamiltonian(3) == Ht);
        CHECK(modified_first.modified_hamiltonian(3) == Ht);
        CHECK(modified_first.terms() == S);
        // a smaller request is the prefix of what is kept
        CHECK(modified_first.modified_hamiltonian(1) == std::vector<Poly>(Ht.begin(), Ht.begin() + 2));
    }
}

TEST_CASE("Scheme: the checks report class, Jacobi, Casimirs and the realisation identities below degree k") {
    const Scene s = test::bundled("rigid_body");
    const SchemeChecks& c = s.scheme->checks();
    CHECK(c.structure_class == StructureClass::linear);
    CHECK_FALSE(c.jacobi);
    REQUIRE(c.casimirs.size() == s.casimirs.size());
    CHECK_FALSE(c.casimirs[0]);
    CHECK(c.realisation_checked);
    CHECK(c.realisation_checked_below_degree == s.order);
    CHECK(c.ok());
    const Scene bad = load_scene(std::string(PGI_SCENES_DIR) + "/../../tests/bad_scenes/jacobi_failure.toml");
    const Scheme& broken = *bad.scheme;
    CHECK(broken.checks().jacobi);
    CHECK_FALSE(broken.checks().realisation_checked);
    CHECK_FALSE(broken.checks().ok());
    CHECK_THROWS_AS(broken.require_valid(), InputError);
    // every artefact built on S_1..S_k refuses a structure that fails Jacobi, whoever asks (CLI, Python, C++)
    const Eigen::VectorXd x = Eigen::VectorXd::Ones(Eigen::Index(broken.phase_space().dim()));
    CHECK_THROWS_WITH_AS(broken.terms(), doctest::Contains("the Jacobi identity fails at"), InputError);
    CHECK_THROWS_AS(broken.stepper(0.1, x), InputError);
    CHECK_THROWS_AS(broken.modified_hamiltonian(2), InputError);
    CHECK(broken.stats().terms_builds == 0);
}

namespace {

// The bundled rigid body's scene as plain values (its Casimir left out).
SchemeValues rigid_body_values(const Scene& s) {
    SchemeValues v;
    v.coordinates = s.phase_space().coordinates();
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = i + 1; j < 3; ++j)
            v.brackets.emplace_back(v.coordinates[i] + "," + v.coordinates[j], s.pi(i, j).to_string());
    v.hamiltonian = s.H.to_string();
    v.order = long(s.order);
    return v;
}

}  // namespace

TEST_CASE("Scheme: from strings equals the scene, and bad values name their entry") {
    const Scene s = test::bundled("rigid_body");
    SchemeValues v = rigid_body_values(s);
    v.casimirs = {s.casimirs[0].to_string()};
    const Scheme scheme = Scheme::from_values(v);
    auto texts = [](const std::vector<Poly>& v) {
        std::vector<std::string> out;
        for (const auto& p : v) out.push_back(p.to_string());
        return out;
    };
    CHECK(texts(scheme.terms()) == texts(s.scheme->terms()));
    CHECK(texts(Scheme(v).terms()) == texts(s.scheme->terms()));
    CHECK(scheme.realisation_form() == RealisationForm::lie_poisson);
    CHECK(scheme.method_order() == 2 * ((s.order + 1) / 2));

    auto key_of = [&](auto change) {
        SchemeValues w = v;
        change(w);
        try {
            Scheme::from_values(w);
        } catch (const InputError& e) {
            return e.key();
        }
        return std::string("no error");
    };
    CHECK(key_of([](SchemeValues& w) { w.brackets[0].first = "x1;x2"; }) == "brackets.\"x1;x2\"");
    CHECK(key_of([](SchemeValues& w) { w.brackets.emplace_back("x2,x1", "-x3"); }) == "brackets.\"x2,x1\"");
    CHECK(key_of([](SchemeValues& w) { w.brackets[0].first = "x1,q"; }) == "brackets.\"x1,q\"");
    CHECK(key_of([](SchemeValues& w) { w.hamiltonian = "x1^"; }) == "hamiltonian.H");
    CHECK(key_of([](SchemeValues& w) { w.hamiltonian = "q"; }) == "hamiltonian.H");
    CHECK(key_of([](SchemeValues& w) { w.casimirs = {"x1 +"}; }) == "hamiltonian.casimirs[0]");
    CHECK(key_of([](SchemeValues& w) { w.coordinates[1] = "x1"; }) == "coordinates[1]");
    CHECK(key_of([](SchemeValues& w) { w.coordinates = {}; }) == "coordinates");
    CHECK(key_of([](SchemeValues& w) { w.order = 0; }) == "order");
    CHECK(key_of([](SchemeValues& w) { w.realisation = "exact"; }) == "realisation");
    CHECK(key_of([](SchemeValues& w) { w.max_seconds = 0; }) == "max_seconds");
    CHECK(key_of([](SchemeValues& w) { w.max_seconds = std::numeric_limits<double>::quiet_NaN(); }) == "max_seconds");
    PoissonStructure general = test::structure({"x", "y", "z"}, {{0, 1, "z^2"}});
    CHECK_THROWS_AS(Scheme(general, general.phase_space().parse("x"), {}, 2, RealisationChoice::closed_form),
                    InputError);
}

// The budgets a C++ or Python caller gives (pgi's --max-seconds and --max-memory-mb): the exact phase stops with the
// refusal naming them, and a scheme without them does the same work.
TEST_CASE("Scheme: from values bounds the exact phase by the time and memory given") {
    SchemeValues v = rigid_body_values(test::bundled("rigid_body"));
    v.order = 12;
    // (from the parse of H on, whichever operation sees the budget spent first)
    const auto refusal = [&](SchemeValues w) {
        try {
            (void)Scheme::from_values(w).modified_hamiltonian(6);
        } catch (const ResourceLimitError& e) {
            return std::string(e.what());
        }
        return std::string("no refusal");
    };
    SchemeValues slow = v;
    slow.max_seconds = 1e-9;
    const std::string time = refusal(slow);
    CHECK_MESSAGE(
        time.find("above the time budget of 1e-09 s (raise it with --max-seconds or max_seconds)") != std::string::npos,
        time);
    SchemeValues small = v;
    small.max_memory_mb = 1;
    const std::string memory = refusal(small);
    CHECK_MESSAGE(memory.find("above the memory budget of 1 MB (raise it with --max-memory-mb or max_memory_mb)") !=
                      std::string::npos,
                  memory);
    CHECK(refusal(v) == "no refusal");
}

// Copies share their ring's budget: their exact calls run one at a time, so the calls of one copy (each restarting the
// budget's clock) never keep another's computation under way alive past its time budget.
TEST_CASE("Scheme: copies run their exact calls one at a time, each within the time budget") {
    SchemeValues v = rigid_body_values(test::bundled("rigid_body"));
    v.order = 12;
    v.max_seconds = 0.3;
    const Scheme a = Scheme::from_values(v);
    const Scheme b = a;  // NOLINT(performance-unnecessary-copy-initialization): the copy is the subject
    std::atomic<bool> done{false};
    std::atomic<std::size_t> calls{0};
    std::thread other([&] {
        while (!done) {
            (void)b.checks();
            ++calls;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    });
    std::string refusal = "no refusal";
    try {
        (void)a.modified_hamiltonian(32);  // about 10 s of exact work on one core
    } catch (const BudgetExceeded& e) {
        refusal = e.what();
    }
    done = true;
    other.join();
    CHECK_MESSAGE(refusal.find("above the time budget of 0.3 s") != std::string::npos, refusal);
    CHECK(calls > 0);
}

TEST_CASE("Scheme: the step for a (dt, x_typical) is built once and every copy steps alike") {
    const Scene s = test::bundled("lotka_volterra");
    const Eigen::VectorXd x0 = vec(*s.x0);
    NewtonStepper a = s.scheme->stepper(s.dt, x0), b = s.scheme->stepper(s.dt, x0);
    Eigen::VectorXd ia(x0.size()), ib(x0.size());
    REQUIRE(a.step(x0, ia) == StepStatus::ok);
    REQUIRE(b.step(x0, ib) == StepStatus::ok);
    CHECK(ia == ib);
    // the same as a stepper built directly, bit for bit
    StepOptions opt;
    opt.k = s.order;
    opt.dt = s.dt;
    opt.realisation = s.realisation;
    NewtonStepper direct = NewtonStepper::build(s.pi, s.H, opt, x0);
    Eigen::VectorXd id(x0.size());
    REQUIRE(direct.step(x0, id) == StepStatus::ok);
    CHECK(ia == id);
    NewtonStepper half = s.scheme->stepper(s.dt / 2, x0);
    CHECK(half.dt() == s.dt / 2);
    CHECK(half.built_dt() == s.dt / 2);  // a build of its own, planned at its dt
}

TEST_CASE("Scheme: the checks, S_1..S_k and the step share one realisation and one S, in either order") {
    for (const auto& name : {"rigid_body", "lotka_volterra", "henon_heiles", "harmonic_oscillator"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = vec(*s.x0);
        Scheme checks_first = *s.scheme, step_first = *s.scheme;  // copies start empty
        CHECK(checks_first.checks().ok());
        checks_first.terms();
        (void)checks_first.stepper(s.dt, x0);
        (void)step_first.stepper(s.dt, x0);
        CHECK(step_first.checks().ok());
        step_first.terms();
        for (const Scheme* scheme : {&checks_first, &step_first}) {
            const SchemeStats st = scheme->stats();
            CHECK(st.realisation_builds == 1);
            CHECK(st.terms_builds == 1);
            CHECK(st.stepper_builds == 1);
        }
    }
}

TEST_CASE(
    "Scheme: each dt gets a build planned at it, the exact phase computed once; a build's run-time dt below its own "
    "agrees to round-off") {
    for (const auto& name : {"rigid_body", "lotka_volterra", "henon_heiles", "nambu"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const Eigen::VectorXd x0 = vec(*s.x0);
        const Scheme scheme = *s.scheme, fresh = *s.scheme;
        NewtonStepper big = scheme.stepper(0.1, x0);
        const SchemeStats before = scheme.stats();
        NewtonStepper own = scheme.stepper(0.05, x0);
        const SchemeStats after = scheme.stats();
        CHECK(after.stepper_builds == before.stepper_builds + 1);
        CHECK(after.realisation_builds == before.realisation_builds);
        CHECK(after.terms_builds == before.terms_builds);
        CHECK(own.built_dt() == 0.05);
        CHECK(own.dt() == 0.05);
        // its S_dt summed at 0.05 (not the stacked S_j and Horner); the same dt again is served by the kept build
        CHECK(own.with_hessian().planned_at(0.05) != nullptr);
        (void)scheme.stepper(0.05, x0);
        CHECK(scheme.stats().stepper_builds == after.stepper_builds);
        // a build at 0.05 of another scheme of the same problem (its own exact phase) takes the same steps, bit for bit
        NewtonStepper other = fresh.stepper(0.05, x0);
        Eigen::VectorXd a = x0, b = x0, c = x0, ia(x0.size()), ib(x0.size()), ic(x0.size());
        // The build at 0.1 stepping 0.05 (its run-time dt) and the build at 0.05 both solve alpha(xb, grad S_dt(xb)) =
        // x at the same dt, each accepted only within its componentwise tolerance (last_tolerance(): 64 u (|x| + the
        // sizes of the terms summed)), and add the same increment expression; they differ only in the predictor's
        // start (its order) and, for a truncated series, in neglected terms below u/4 |x|. So each step's states
        // differ by at most about the two tolerances, and over N steps of this Poisson map (no exponential growth
        // over t = N dt = 1) by N times that.
        double bound = 0;
        const int N = 20;
        for (int i = 0; i < N; ++i) {
            REQUIRE(own.step(a, ia) == StepStatus::ok);
            REQUIRE(other.step(b, ib) == StepStatus::ok);
            REQUIRE(big.step(c, 0.05, ic) == StepStatus::ok);
            a += ia, b += ib, c += ic;
            bound += 2 * std::max(own.last_tolerance(), big.last_tolerance());
        }
        CHECK(a == b);
        CHECK((c - a).lpNorm<Eigen::Infinity>() <= bound);
    }
}

TEST_CASE("Scheme: the stepper cache is bounded") {
    const Scene s = test::bundled("rigid_body");
    const Scheme scheme = *s.scheme;
    const Eigen::VectorXd x0 = vec(*s.x0);
    for (int i = 1; i <= int(Scheme::stepper_cache_size) + 4; ++i)
        (void)scheme.stepper(0.01 * i, x0);  // each dt a build
    CHECK(scheme.stats().stepper_builds == Scheme::stepper_cache_size + 4);
    CHECK(scheme.stats().steppers_kept == Scheme::stepper_cache_size);
    (void)scheme.stepper(0.01 * (Scheme::stepper_cache_size + 4), x0);  // the newest: served by its kept build
    CHECK(scheme.stats().stepper_builds == Scheme::stepper_cache_size + 4);
    (void)scheme.stepper(0.01, x0);  // the oldest: dropped, built again
    CHECK(scheme.stats().stepper_builds == Scheme::stepper_cache_size + 5);
}

TEST_CASE("Scheme: a report computes the realisation, S, Htilde and the step once each") {
    for (const auto& name : {"rigid_body", "lotka_volterra", "henon_heiles"}) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        const auto data = report_data(s, 4);
        const SchemeStats st = s.scheme->stats();
        CHECK(st.realisation_builds == 1);
        CHECK(st.terms_builds == 1);
        CHECK(st.modified_builds == 1);
        CHECK(st.stepper_builds == (s.x0 && s.t_end ? 1 : 0));
        CHECK(data["S"].size() == s.order);
    }
}

// The build sizes its truncated realisation by the sizes of the terms at the magnitudes it serves, and serves each
// coordinate up to twice its own magnitude: built where the bracket vanishes (x = 0 in x^2 + x y) or its terms
// cancel ((x + y)^2, x^2 - y^2 at (1, -1)), the kept step chose its lowest degree there and failed the next run
// (truncation above its bound) where a fresh scheme succeeds.
TEST_CASE("Scheme: a step built where the bracket's terms vanish or cancel still serves the runs it is kept for") {
    struct Case {
        std::string bracket;
        Eigen::Vector2d first, then;
    };
    for (const Case& c : {Case{"x^2 + x*y", {0.0, 1.0}, {0.5, 0.5}}, Case{"x^2 + 2*x*y + y^2", {1.0, -1.0}, {1.0, 1.0}},
                          Case{"x^2 - y^2", {1.0, -1.0}, {1.0, 0.5}}}) {
        CAPTURE(c.bracket);
        const Scheme kept(test::radial_plane(c.bracket)), fresh(test::radial_plane(c.bracket));
        REQUIRE(integrate(kept, c.first, 0.1, 1.0).status == StepStatus::ok);
        const Trajectory again = integrate(kept, c.then, 0.1, 1.0), alone = integrate(fresh, c.then, 0.1, 1.0);
        REQUIRE(alone.status == StepStatus::ok);
        CHECK(again.status == StepStatus::ok);
        REQUIRE(again.x.size() == alone.x.size());
        // the same method at degrees whose neglected terms are below u/4 of |x| a step: ten steps agree to 1e-13
        for (std::size_t i = 0; i < again.x.size(); ++i) CHECK(std::abs(again.x[i] - alone.x[i]) < 1e-13);
    }
}

// {x, y} = x^2 + y^2 with H = |x|^2/2 from (2, 1): p = grad S_dt is nearly parallel to x at every state, where the
// values of the neglected parts cancel; sized by them the build chose D = 5, and the run ended "ok" off by 1.1e-4.
TEST_CASE("Scheme: a truncated realisation is sized by its terms where their values cancel along the run") {
    const Eigen::Vector2d start(2.0, 1.0);
    const Trajectory own = integrate(Scheme(test::radial_plane("x^2 + y^2")), start, 0.1, 1.0);
    // the same run, its step built for three times the state's magnitudes: a degree well past what either needs
    const Trajectory wide =
        integrate(Scheme(test::radial_plane("x^2 + y^2")), start, 0.1, 1.0, 1, Eigen::Vector2d(3.0, 3.0));
    REQUIRE(own.status == StepStatus::ok);
    REQUIRE(wide.status == StepStatus::ok);
    REQUIRE(own.x.size() == wide.x.size());
    // ten steps of two methods that each solve to round-off: |x| ~ 2, a few ulps a step
    for (std::size_t i = 0; i < own.x.size(); ++i) CHECK(std::abs(own.x[i] - wide.x[i]) < 1e-13);
}
