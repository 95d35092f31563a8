// Parameters (scheme/scheme.hpp, Parameter): symbols of the exact phase, given values at run time. A run with values w
// equals, to round-off, the scheme with w written into H; the exact phase is built once whatever the values.
#include "scheme/ensemble.hpp"
#include "scheme/evaluators.hpp"
#include "scheme/trajectory.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>

using namespace pgi;

namespace {

// The rigid body with inverse moments of inertia w1, w2, w3: parameters, or the exact values given (substituted).
SchemeValues rigid_body(bool parameters, const std::string& w1 = "1/2", const std::string& w2 = "1",
                        const std::string& w3 = "3/2") {
    SchemeValues v;
    v.coordinates = {"x1", "x2", "x3"};
    v.brackets = {{"x1,x2", "-x3"}, {"x2,x3", "-x1"}, {"x3,x1", "-x2"}};
    const std::string a = parameters ? "w1" : "(" + w1 + ")", b = parameters ? "w2" : "(" + w2 + ")",
                      c = parameters ? "w3" : "(" + w3 + ")";
    v.hamiltonian = "1/2*" + a + "*x1^2 + 1/2*" + b + "*x2^2 + 1/2*" + c + "*x3^2";
    v.casimirs = {"x1^2 + x2^2 + x3^2"};
    v.order = 4;
    if (parameters) v.parameters = {{"w1", w1}, {"w2", w2}, {"w3", w3}};
    return v;
}

double relative_difference(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return (a - b).lpNorm<Eigen::Infinity>() / b.lpNorm<Eigen::Infinity>();
}

const Eigen::Vector3d x0(0.4535961214255773, 0.0, 0.8912073600614354);

// The final state of a run of t_end = 5 (50 steps of 1/10).
Eigen::VectorXd final_state(const Scheme& s, const ParameterValues& w = {}) {
    const Trajectory tr = integrate(s, x0, 0.1, 5.0, 1, std::nullopt, {}, {}, w);
    REQUIRE(tr.status == StepStatus::ok);
    return Eigen::Map<const Eigen::VectorXd>(tr.x.data() + tr.x.size() - 3, 3);
}

}  // namespace

TEST_CASE("parameters: a scene's [parameters] are read exactly, decimals included") {
    const Scene scene = test::bundled("rigid_body_parameters");
    REQUIRE(scene.parameters.size() == 3);
    CHECK(scene.parameters[0].name == "w1");
    CHECK(scene.parameters[0].value == Rational(1, 2));
    CHECK(scene.parameters[2].value == Rational(3, 2));  // "1.5"
    CHECK(scene.dim() == 3);
    CHECK(scene.scheme->dim() == 3);
    CHECK(scene.scheme->coordinates() == std::vector<std::string>{"x1", "x2", "x3"});
    CHECK(scene.scheme->phase_space().dim() == 6);
    SchemeValues v = rigid_body(true, "0.05");
    CHECK(Scheme(v).parameters()[0].value == Rational(1, 20));
}

TEST_CASE("parameters: the checks hold for every value, the closed form is kept") {
    const Scheme s(rigid_body(true));
    const SchemeChecks& c = s.checks();
    CHECK(c.ok());
    CHECK(c.structure_class == StructureClass::linear);
    CHECK(s.realisation_form() == RealisationForm::lie_poisson);
    // a Casimir that holds only with the parameters as symbols: w1 (x1^2 + x2^2 + x3^2) + w2 w3
    SchemeValues v = rigid_body(true);
    v.casimirs.push_back("w1*(x1^2 + x2^2 + x3^2) + w2*w3");
    CHECK(Scheme(v).checks().ok());
    v.casimirs.back() = "w1*x1^2";
    CHECK_THROWS_AS(Scheme(v).require_valid(), InputError);
}

TEST_CASE("parameters: S_1..S_k are polynomials in the coordinates and the parameters") {
    const Scheme s(rigid_body(true));
    const std::vector<Poly>& S = s.terms();
    REQUIRE(S.size() == 4);
    CHECK(S[0] == s.hamiltonian());
    CHECK(S[1].is_zero());
    const auto vars = used_variables(S[2]);
    CHECK(std::find(vars.begin(), vars.end(), s.phase_space().x(3)) != vars.end());  // w1
    CHECK(S[2].to_string().find("w2") != std::string::npos);
}

TEST_CASE("parameters: a run with values equals the scheme with the values written in, one exact phase") {
    const Scheme s(rigid_body(true));
    const std::vector<std::array<std::string, 3>> values{
        {"1/2", "1", "3/2"}, {"2/5", "7/10", "9/4"}, {"1", "1/3", "5"}, {"-1/2", "3", "1/7"}};
    for (const auto& row : values) {
        const std::string &a = row[0], &b = row[1], &c = row[2];  // (names, not bindings: CAPTURE is a lambda)
        CAPTURE(a);
        const Scheme written(rigid_body(false, a, b, c));
        const Eigen::VectorXd expected = final_state(written);
        const ParameterValues w{{"w1", {Rational::parse(a).to_double()}},
                                {"w2", {Rational::parse(b).to_double()}},
                                {"w3", {Rational::parse(c).to_double()}}};
        CHECK(relative_difference(final_state(s, w), expected) < 1e-13);
    }
    CHECK(s.stats().terms_builds == 1);
    CHECK(s.stats().realisation_builds == 1);
}

// A predictor term's coefficient with parameters is a polynomial in them, bound once: counting its terms in (x, w)
// made the choice stop at order 4 where the scheme with the values written in takes 7 (k = 10, dt = 0.3), and Newton
// then took 1.7 iterations a step instead of 1.
TEST_CASE("parameters: the predictor is chosen as with the values written in, its cost the terms its map evaluates") {
    for (const auto& [k, dt] : {std::pair{std::size_t(10), 0.3}, std::pair{std::size_t(8), 0.2}}) {
        CAPTURE(k);
        SchemeValues with = rigid_body(true), written = rigid_body(false);
        with.order = written.order = k;
        const Scheme a(with), b(written);
        Eigen::VectorXd extended(6);
        extended << x0, 0.5, 1.0, 1.5;
        NewtonStepper pa = a.stepper(dt, extended), pb = b.stepper(dt, x0);
        CHECK(pa.predictor().order() + 1 >= pb.predictor().order());
        double iterations_a = 0, iterations_b = 0;
        Eigen::VectorXd xa = extended, xb = x0, da(6), db(3);
        for (int n = 0; n < 100; ++n) {
            REQUIRE(pa.step(xa, da) == StepStatus::ok);
            REQUIRE(pb.step(xb, db) == StepStatus::ok);
            xa += da, xb += db;
            iterations_a += pa.last_iterations(), iterations_b += pb.last_iterations();
        }
        CHECK(iterations_a <= iterations_b + 10);
    }
}

// A step measures sizes (Newton's scale, its tolerance, the predictor's error, the Lie-Poisson series' term sizes)
// over the coordinates that move: a parameter's value is not the state's size. Parameters (a, e) entering H as their
// product a e, at (1, 1/2) and rescaled by powers of two, bind the same coefficients exactly, so the runs must agree
// bit for bit. Sized by every coordinate, a = 2^30 made the predictor's error look 2^-30 as large (order 0 was
// chosen) and Newton's "small" correction 2^30 times too lax: 2-3 iterations a step, and on sl(2)* an energy error
// of 1e-6 where the unscaled run keeps 1e-13.
TEST_CASE("parameters: a step sizes the state by its coordinates, so rescaled parameters change no bit of a run") {
    struct Case {
        std::string name, brackets[3], hamiltonian, casimir;
        long k;
        double dt;
    };
    const Case cases[] = {
        {"rigid body (so(3) closed form)",
         {"-x3", "-x1", "-x2"},
         "a*e*x1^2/2 + x2^2/2 + 3/4*x3^2",
         "x1^2 + x2^2 + x3^2",
         10,
         0.3},
        {"sl(2)* (Lie-Poisson series)",
         {"-x3", "x1", "x2"},
         "a*e*x1^2/2 + x2^2 + x3^2/2",
         "x1^2 + x2^2 - x3^2",
         4,
         0.1},
    };
    for (const Case& c : cases) {
        CAPTURE(c.name);
        SchemeValues v;
        v.coordinates = {"x1", "x2", "x3"};
        v.brackets = {{"x1,x2", c.brackets[0]}, {"x2,x3", c.brackets[1]}, {"x3,x1", c.brackets[2]}};
        v.hamiltonian = c.hamiltonian;
        v.casimirs = {c.casimir};
        v.order = c.k;
        v.parameters = {{"a", "1"}, {"e", "1/2"}};
        const Trajectory unscaled = integrate(Scheme(v), x0, c.dt, 300 * c.dt, 1, std::nullopt, {}, {}, {});
        REQUIRE(unscaled.status == StepStatus::ok);
        CHECK(unscaled.newton_iterations_max == 1);
        for (const int power : {30, -30}) {
            CAPTURE(power);
            // a scheme of its own: its step is built at these values (the predictor, the truncation and the Newton
            // matrix's Hessian terms chosen there), as well as run at them
            const ParameterValues w{{"a", {std::ldexp(1.0, power)}}, {"e", {std::ldexp(0.5, -power)}}};
            const Trajectory scaled = integrate(Scheme(v), x0, c.dt, 300 * c.dt, 1, std::nullopt, {}, {}, w);
            REQUIRE(scaled.status == StepStatus::ok);
            CHECK(scaled.newton_iterations_max == 1);
            REQUIRE(scaled.x.size() == unscaled.x.size());
            std::size_t differ = 0;
            for (std::size_t i = 0; i < scaled.x.size(); ++i)
                differ += std::bit_cast<std::uint64_t>(scaled.x[i]) != std::bit_cast<std::uint64_t>(unscaled.x[i]);
            CHECK(differ == 0);
        }
    }
}

// A Scheme keeps the steps it built, each serving typical states up to twice its own size; the parameters' values are
// not a size, but the build's choices read them (through S_j): a step serves each parameter up to twice the magnitude
// it was built at, at the same sign. (Built at e = 1/2, a kept step served e = 5, where its truncation had been chosen
// for terms ten times smaller: the run failed, truncation above its bound; across a sign, e x^2 + 5 x^2 built at
// e = -5, where x^2 cancels, failed at e = 5.)
TEST_CASE("parameters: a kept step serves values up to twice its own at the same sign, others build again") {
    const auto scheme = [](const std::string& hamiltonian, const std::string& e) {
        SchemeValues v;
        v.coordinates = {"x", "y"};
        v.brackets = {{"x,y", "x^2 + y^2"}};
        v.hamiltonian = hamiltonian;
        v.order = 4;
        v.realisation = "radial";
        v.parameters = {{"e", e}};
        return v;
    };
    const Eigen::Vector2d start(0.8, 0.3);
    const auto run = [&](const Scheme& s, double e) {
        return integrate(s, start, 0.05, 1.0, 20, std::nullopt, {}, {}, {{"e", {e}}});
    };
    const SchemeValues v = scheme("e*x^2/2 + y^2", "1/2");
    const Scheme kept(v);
    REQUIRE(run(kept, 0.5).status == StepStatus::ok);
    REQUIRE(run(kept, 0.75).status == StepStatus::ok);
    REQUIRE(run(kept, 0.25).status == StepStatus::ok);
    CHECK(kept.stats().stepper_builds == 1);  // a sweep of single runs near the value shares one build
    const Trajectory again = run(kept, 5.0), fresh = run(Scheme(v), 5.0);
    CHECK(kept.stats().stepper_builds == 2);
    REQUIRE(fresh.status == StepStatus::ok);
    REQUIRE(again.status == StepStatus::ok);
    CHECK(again.x == fresh.x);
    const Scheme cancelling(scheme("e*x^2/2 + 5*x^2/2 + y^2", "-5"));
    REQUIRE(run(cancelling, -5.0).status == StepStatus::ok);
    CHECK(run(cancelling, 5.0).status == StepStatus::ok);
    CHECK(cancelling.stats().stepper_builds == 2);
}

TEST_CASE("parameters: an ensemble sweeps one value per trajectory, equal to the schemes with the values written in") {
    const Scheme s(rigid_body(true));
    constexpr std::size_t m = 40;
    std::vector<double> w1(m), w3(m);
    std::vector<std::string> w1_text(m), w3_text(m);
    for (std::size_t j = 0; j < m; ++j) {
        w1_text[j] = std::to_string(20 + j) + "/40", w3_text[j] = std::to_string(60 - j) + "/40";
        w1[j] = Rational::parse(w1_text[j]).to_double(), w3[j] = Rational::parse(w3_text[j]).to_double();
    }
    RowMatrix X0(Eigen::Index(m), 3);
    for (Eigen::Index j = 0; j < X0.rows(); ++j) X0.row(j) = x0.transpose();
    EnsembleOptions o;
    o.parameters = {{"w1", w1}, {"w3", w3}};  // w2 keeps its default, 1
    const EnsembleResult r = integrate_ensemble(s, X0, 0.1, 5.0, o);
    REQUIRE(r.x.cols() == 3);
    for (std::size_t j = 0; j < m; j += 7) {
        CAPTURE(j);
        CHECK(r.members[j].status == TrajectoryStatus::ok);
        const Eigen::VectorXd expected = final_state(Scheme(rigid_body(false, w1_text[j], "1", w3_text[j])));
        CHECK(relative_difference(r.x.row(Eigen::Index(j)).transpose(), expected) < 1e-13);
        CHECK(r.casimir_error(Eigen::Index(j), 0) < 1e-14);
    }
    CHECK(s.stats().terms_builds == 1);
}

// An ensemble builds one step for all its rows: at the typical coordinates (the largest row's) with each parameter at
// its largest magnitude over the rows. Built at the row of largest norm, coordinates and parameters together, a row
// with three times the others' coordinates beside one whose parameter a is 1000 got a step sized for the small
// coordinates, and ended truncation_above_bound (a e = 1/2 in both: the same flow). Here twice and 4: the radial
// realisation this structure needs deepens fast with both, and 3 and 1000 cost a minute of exact phase.
TEST_CASE("parameters: an ensemble's step is sized for its largest coordinates and its largest parameters at once") {
    SchemeValues v;
    v.coordinates = {"x1", "x2", "x3"};
    v.brackets = {{"x1,x2", "x3^2"}, {"x2,x3", "x1^2"}, {"x3,x1", "x2^2"}};
    v.hamiltonian = "a*e*x1^2 + (x2^2 + x3^2)/2";
    v.casimirs = {"x1^3 + x2^3 + x3^3"};
    v.order = 4;
    v.realisation = "radial";
    v.parameters = {{"a", "1"}, {"e", "1/2"}};
    const Eigen::Vector3d x0(0.6, 0.8, 0.3);
    RowMatrix X0(2, 3);
    X0.row(0) = 2 * x0.transpose();
    X0.row(1) = x0.transpose();
    EnsembleOptions o;
    o.parameters = {{"a", {1.0, 4.0}}, {"e", {0.5, 0.125}}};
    const Scheme s(v);
    const EnsembleResult r = integrate_ensemble(s, X0, 0.05, 5.0, o);
    for (std::size_t j = 0; j < 2; ++j) {
        CAPTURE(j);
        CHECK(r.members[j].status == TrajectoryStatus::ok);
        const Eigen::VectorXd start = X0.row(Eigen::Index(j)).transpose();
        // the kept step (every value of the same sign, at most the largest) serves the row's single run: its bits
        const Trajectory one = integrate(s, start, 0.05, 5.0, 100, r.x_typical, {}, {},
                                         {{"a", {o.parameters[0].second[j]}}, {"e", {o.parameters[1].second[j]}}});
        REQUIRE(one.status == StepStatus::ok);
        for (Eigen::Index i = 0; i < 3; ++i)
            CHECK(std::bit_cast<std::uint64_t>(r.x(Eigen::Index(j), i)) ==
                  std::bit_cast<std::uint64_t>(one.x[one.x.size() - 3 + std::size_t(i)]));
    }
    CHECK(s.stats().stepper_builds == 1);
}

TEST_CASE("parameters: a parameterised Casimir stays at round-off along a run") {
    SchemeValues v = rigid_body(true);
    v.casimirs = {"w1*(x1^2 + x2^2 + x3^2) + w2*w3"};
    const Scheme s(v);
    const Trajectory tr = integrate(s, x0, 0.1, 100.0, 10, std::nullopt, {}, {}, {{"w1", {3.0}}, {"w3", {0.7}}});
    REQUIRE(tr.status == StepStatus::ok);
    CHECK(tr.casimir_error_max[0] < 1e-14);
    CHECK(tr.energy_error_max < 1e-5);
}

TEST_CASE("parameters: the evaluators take the parameters' values") {
    const Scheme s(rigid_body(true));
    RowMatrix X(2, 3);
    X << 0.3, -0.4, 0.5, 1.0, 2.0, -1.0;
    const RowMatrix F = vector_field(s, X, {{"w1", {2.0, 0.5}}});
    const Scheme written(rigid_body(false, "2", "1", "3/2"));
    CHECK(relative_difference(F.row(0).transpose(), vector_field(written, X).row(0).transpose()) < 1e-15);
    const Eigen::VectorXd H = hamiltonian_values(s, X, {{"w2", {4.0}}});
    CHECK(H[0] == doctest::Approx(0.25 * 0.09 + 2 * 0.16 + 0.75 * 0.25));
}

TEST_CASE("parameters: bad input is refused with an InputError naming it") {
    const Scheme s(rigid_body(true));
    RowMatrix X0(2, 3);
    X0.setOnes();
    CHECK_THROWS_WITH_AS(s.parameter_rows({{"I1", {1.0}}}),
                         "parameters: unknown parameter 'I1' (the scheme's parameters: w1, w2, w3)", InputError);
    CHECK_THROWS_WITH_AS(s.parameter_rows({{"w1", {std::numeric_limits<double>::quiet_NaN()}}}),
                         "parameters.w1: its value at row 0 is not finite", InputError);
    EnsembleOptions o;
    o.parameters = {{"w2", {1.0, 2.0, 3.0}}};
    CHECK_THROWS_WITH_AS(integrate_ensemble(s, X0, 0.1, 1.0, o),
                         "parameters.w2: has 3 values, for 2 trajectories (give 1 value, or one per trajectory)",
                         InputError);
    CHECK_THROWS_WITH_AS(integrate(s, x0, 0.1, 1.0, 1, std::nullopt, {}, {}, {{"w1", {1.0}}, {"w1", {2.0}}}),
                         "parameters: parameter 'w1' given twice", InputError);
    SchemeValues v = rigid_body(true);
    v.brackets[0].second = "-w1*x3";
    CHECK_THROWS_WITH_AS(Scheme::from_values(v),
                         "brackets.\"x1,x2\": uses the parameter 'w1': parameters are allowed in H and the Casimirs, "
                         "not in brackets (the structure's class and realisation are decided with them as coordinates)",
                         InputError);
    v = rigid_body(true);
    v.brackets.emplace_back("x1,w2", "x1");
    CHECK_THROWS_WITH_AS(Scheme::from_values(v),
                         "brackets.\"x1,w2\": 'w2' is a parameter: parameters Poisson-commute with everything",
                         InputError);
    v = rigid_body(true);
    v.parameters[1] = {"x2", "1"};
    CHECK_THROWS_WITH_AS(Scheme::from_values(v), "parameters.x2: 'x2' is also a coordinate", InputError);
    v = rigid_body(true, "one");
    CHECK_THROWS_AS(Scheme::from_values(v), InputError);
    const Scheme plain(rigid_body(false));
    CHECK_THROWS_WITH_AS(integrate(plain, x0, 0.1, 1.0, 1, std::nullopt, {}, {}, {{"w1", {1.0}}}),
                         "parameters: unknown parameter 'w1' (the scheme's parameters: none)", InputError);
}

TEST_CASE("parameters: a bracket that uses a parameter in a scene names the bracket") {
    const std::string text =
        "name = \"s\"\ncoordinates = [\"q\", \"p\"]\n[parameters]\nk = \"2\"\n[brackets]\n\"q,p\" = \"k\"\n"
        "[hamiltonian]\nH = \"p^2/2 + k*q^2/2\"\n";
    CHECK_THROWS_WITH_AS(parse_scene(text, "s.toml"),
                         "s.toml: brackets.\"q,p\": uses the parameter 'k': parameters are allowed in H and the "
                         "Casimirs, not in brackets (the structure's class and realisation are decided with them as "
                         "coordinates)",
                         SceneError);
    const std::string bad_value =
        "name = \"s\"\ncoordinates = [\"q\", \"p\"]\n[parameters]\nk = 0.5\n[brackets]\n\"q,p\" = \"1\"\n"
        "[hamiltonian]\nH = \"p^2/2 + k*q^2/2\"\n";
    CHECK_THROWS_WITH_AS(parse_scene(bad_value, "s.toml"),
                         "s.toml: parameters.k: must be a string holding an exact value (\"2\", \"-1/3\", \"0.05\") "
                         "or an integer",
                         SceneError);
}

namespace {

// Henon-Heiles with its three constants as parameters a, b, c (a canonical structure: the compiled polynomial
// realisation), or the values given written in.
SchemeValues henon_heiles(bool parameters, const std::string& a = "1", const std::string& b = "1",
                          const std::string& c = "1") {
    SchemeValues v;
    v.coordinates = {"q1", "q2", "p1", "p2"};
    v.brackets = {{"q1,p1", "1"}, {"q2,p2", "1"}};
    const auto value = [&](const char* name, const std::string& text) { return parameters ? name : "(" + text + ")"; };
    v.hamiltonian = "(p1^2 + p2^2)/2 + " + value("a", a) + "*(q1^2 + q2^2)/2 + " + value("b", b) + "*q1^2*q2 - " +
                    value("c", c) + "*q2^3/3";
    v.order = 4;
    if (parameters) v.parameters = {{"a", a}, {"b", b}, {"c", c}};
    return v;
}

// The cyclic Lotka-Volterra system with H = a x1 + b x2 + c x3 (log-canonical), its Casimir x1 x2 x3.
SchemeValues lotka_volterra(bool parameters, const std::string& a = "1", const std::string& b = "1",
                            const std::string& c = "1") {
    SchemeValues v;
    v.coordinates = {"x1", "x2", "x3"};
    v.brackets = {{"x1,x2", "x1*x2"}, {"x2,x3", "x2*x3"}, {"x3,x1", "x3*x1"}};
    const auto value = [&](const char* name, const std::string& text) { return parameters ? name : "(" + text + ")"; };
    v.hamiltonian = value("a", a) + "*x1 + " + value("b", b) + "*x2 + " + value("c", c) + "*x3";
    v.casimirs = {"x1*x2*x3"};
    v.order = 4;
    if (parameters) v.parameters = {{"a", a}, {"b", b}, {"c", c}};
    return v;
}

}  // namespace

TEST_CASE("parameters: canonical and log-canonical sweeps step the coordinates alone, equal to the values written in") {
    using Make = SchemeValues (*)(bool, const std::string&, const std::string&, const std::string&);
    struct Case {
        Make make;
        Eigen::VectorXd x0;
        double dt;
        std::size_t coordinates;
    };
    const Case cases[] = {{henon_heiles, Eigen::Vector4d(0.1, -0.1, 0.2, 0.1), 0.1, 4},
                          {lotka_volterra, Eigen::Vector3d(1.0, 2.0, 0.5), 0.05, 3}};
    for (const Case& c : cases) {
        const Scheme s(c.make(true, "1", "1", "1"));
        CAPTURE(s.coordinates().size());
        // the realisation leaves the parameters alone and nothing reads them: Newton on the coordinates, on lanes
        const Eigen::VectorXd typical = Eigen::VectorXd::Ones(Eigen::Index(s.phase_space().dim()));
        CHECK(s.stepper(c.dt, typical).lane_dimension() == c.coordinates);
        constexpr std::size_t m = 20;  // two full blocks of lanes and a partial one
        std::vector<double> a(m), b(m), cc(m);
        std::vector<std::string> at(m), bt(m), ct(m);
        for (std::size_t j = 0; j < m; ++j) {
            at[j] = std::to_string(30 + j) + "/40", bt[j] = std::to_string(50 - j) + "/40",
            ct[j] = std::to_string(j % 7 + 3) + "/5";
            a[j] = Rational::parse(at[j]).to_double(), b[j] = Rational::parse(bt[j]).to_double(),
            cc[j] = Rational::parse(ct[j]).to_double();
        }
        RowMatrix X0(Eigen::Index(m), c.x0.size());
        for (Eigen::Index j = 0; j < X0.rows(); ++j) X0.row(j) = c.x0.transpose();
        EnsembleOptions o;
        o.parameters = {{"a", a}, {"b", b}, {"c", cc}};
        const EnsembleResult r = integrate_ensemble(s, X0, c.dt, 5.0, o);
        for (std::size_t j = 0; j < m; ++j) {
            CAPTURE(j);
            REQUIRE(r.members[j].status == TrajectoryStatus::ok);
            const Trajectory tr = integrate(Scheme(c.make(false, at[j], bt[j], ct[j])), c.x0, c.dt, 5.0, 1);
            REQUIRE(tr.status == StepStatus::ok);
            const auto n = Eigen::Index(c.x0.size());
            const Eigen::VectorXd expected = Eigen::Map<const Eigen::VectorXd>(tr.x.data() + tr.x.size() - n, n);
            CHECK(relative_difference(r.x.row(Eigen::Index(j)).transpose(), expected) < 1e-13);
            if (r.casimir_error.cols() > 0) CHECK(r.casimir_error(Eigen::Index(j), 0) < 1e-14);
        }
        CHECK(s.stats().terms_builds == 1);
    }
}

TEST_CASE("parameters: a scheme whose coordinates have no lane step of their own keeps the one of all its dimensions") {
    // five log-canonical coordinates (no LaneStep<5>) and one parameter: LaneStep<6> over all six, as without the
    // leading-coordinates rule, and the run equals the scheme with the value written in
    const auto lattice = [](bool parameter) {
        SchemeValues v;
        v.coordinates = {"x1", "x2", "x3", "x4", "x5"};
        v.brackets = {{"x1,x2", "x1*x2"}, {"x2,x3", "x2*x3"}, {"x3,x4", "x3*x4"}, {"x4,x5", "x4*x5"}};
        v.hamiltonian = std::string(parameter ? "a" : "(3/4)") + "*x1 + x2 + x3 + x4 + x5";
        v.order = 4;
        if (parameter) v.parameters = {{"a", "3/4"}};
        return v;
    };
    const Scheme s(lattice(true));
    CHECK(s.stepper(0.05, Eigen::VectorXd::Ones(6)).lane_dimension() == 6);
    const Eigen::VectorXd x0 = (Eigen::VectorXd(5) << 1.0, 0.5, 2.0, 1.5, 0.8).finished();
    const Trajectory with = integrate(s, x0, 0.05, 2.0, 1),
                     written = integrate(Scheme(lattice(false)), x0, 0.05, 2.0, 1);
    REQUIRE(with.status == StepStatus::ok);
    REQUIRE(written.status == StepStatus::ok);
    const Eigen::Map<const Eigen::VectorXd> a(with.x.data() + with.x.size() - 5, 5),
        b(written.x.data() + written.x.size() - 5, 5);
    CHECK(relative_difference(a, b) < 1e-13);
}

// Terms that cancel at the build's parameter values (a x^2 y^2 - b x^2 y^2 at a = b) are sized as terms, not as their
// sum: the step kept from a = b = 3 serves a = 6 (the same signs, twice the magnitude); it failed there (truncation
// above its bound) where a fresh scheme succeeds.
TEST_CASE("parameters: a step built where parameters cancel serves the values it is kept for") {
    SchemeValues v = test::radial_plane("x^2 + 1", "a*x^2*y^2 - b*x^2*y^2 + (x^2 + y^2)/2");
    v.parameters = {{"a", "1"}, {"b", "1"}};
    const Scheme kept(v), fresh(v);
    const Eigen::Vector2d start(0.8, 0.6);
    REQUIRE(integrate(kept, start, 0.1, 1.0, 1, std::nullopt, {}, {}, {{"a", {3.0}}, {"b", {3.0}}}).status ==
            StepStatus::ok);
    const ParameterValues apart{{"a", {6.0}}, {"b", {3.0}}};
    const Trajectory again = integrate(kept, start, 0.1, 1.0, 1, std::nullopt, {}, {}, apart);
    const Trajectory alone = integrate(fresh, start, 0.1, 1.0, 1, std::nullopt, {}, {}, apart);
    CHECK(kept.stats().stepper_builds == 1);  // served by the kept step
    REQUIRE(alone.status == StepStatus::ok);
    CHECK(again.status == StepStatus::ok);
    REQUIRE(again.x.size() == alone.x.size());
    for (std::size_t i = 0; i < again.x.size(); ++i) CHECK(std::abs(again.x[i] - alone.x[i]) < 1e-13);
}
