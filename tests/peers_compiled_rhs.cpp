// The peers' own right-hand side (tools/peers/compiled_rhs.hpp, issue 33): the C generated from a scene's exact
// polynomials, compiled by the system C compiler and loaded, equals pgi's vector field (Scheme::vector_field_map) and
// the exact Jacobian to round-off at random states, on every bundled scene; a compiler that fails is an error naming
// it.
#include "scheme/scene.hpp"
#include "series/native.hpp"
#include "tools/peers/compiled_rhs.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

using namespace pgi;
namespace fs = std::filesystem;

namespace {

// The sum of f's terms' absolute values at x (coordinates first in the ring): what round-off in f(x) is relative to.
double term_scale(const Poly& f, const std::vector<double>& point) {
    double s = 0;
    for (std::size_t i = 0; i < f.length(); ++i) {
        double t = std::abs(f.term_coeff(i).to_double());
        const auto e = f.term_exponents(i);
        for (std::size_t v = 0; v < e.size(); ++v) t *= std::pow(std::abs(point[v]), double(e[v]));
        s += t;
    }
    return s;
}

std::vector<fs::path> bundled_scenes() {
    std::vector<fs::path> scenes;
    for (const auto& entry : fs::directory_iterator(PGI_SCENES_DIR))
        if (entry.path().extension() == ".toml") scenes.push_back(entry.path());
    std::sort(scenes.begin(), scenes.end());
    return scenes;
}

}  // namespace

TEST_CASE("peers' compiled C right-hand side equals pgi's vector field and Jacobian on every bundled scene") {
    const auto scenes = bundled_scenes();
    REQUIRE(scenes.size() >= 9);
    std::mt19937 gen(33);
    for (const fs::path& file : scenes) {
        CAPTURE(file.string());
        const Scene scene = load_scene(file);
        const PhaseSpace& M = scene.phase_space();
        const std::size_t n = M.dim();
        const std::vector<Poly> field = scene.pi.hamiltonian_vector_field(scene.H);
        const peers::CompiledRhs rhs = peers::compile_rhs(field, M.coordinate_vars(), M.coordinates(), scene.name);
        REQUIRE(bool(rhs.rhs));
        REQUIRE(bool(rhs.jacobian));
        CHECK(rhs.n == n);
        // pgi's own evaluator of pi grad H, and the exact Jacobian compiled by pgi
        CompiledMap pgi_field = scene.scheme->vector_field_map();  // a copy: eval's scratch is the map's
        std::vector<Poly> jacobian;
        for (const Poly& fi : field)
            for (std::size_t j = 0; j < n; ++j) jacobian.push_back(derivative(fi, M.x(j)));
        CompiledMap pgi_jacobian = CompiledMap::build(jacobian, M.coordinate_vars());
        std::uniform_real_distribution<double> coordinate(-1.5, 1.5);
        for (int sample = 0; sample < 40; ++sample) {
            std::vector<double> x(n);
            for (double& v : x) v = coordinate(gen);
            const std::vector<double> point = M.point(x);
            std::vector<double> f(n, std::nan("")), g(n), J(n * n, std::nan("")), K(n * n), dfdt(n, std::nan(""));
            CHECK(rhs.rhs(0.5, x.data(), f.data(), nullptr) == 0);
            CHECK(rhs.jacobian(0.5, x.data(), J.data(), dfdt.data(), nullptr) == 0);
            pgi_field.eval(x.data(), g.data());
            pgi_jacobian.eval(x.data(), K.data());
            for (std::size_t i = 0; i < n; ++i) {
                CAPTURE(i);
                CHECK(std::abs(f[i] - g[i]) <= 1e-13 * term_scale(field[i], point));
                CHECK(dfdt[i] == 0.0);
                for (std::size_t j = 0; j < n; ++j) {
                    CAPTURE(j);
                    CHECK(std::abs(J[i * n + j] - K[i * n + j]) <= 1e-13 * term_scale(jacobian[i * n + j], point));
                }
            }
        }
    }
}

TEST_CASE("peers' right-hand side source: the coordinates by name, exact coefficients, every Jacobian entry") {
    const Scene scene = load_scene(fs::path(PGI_SCENES_DIR) / "rigid_body.toml");
    const PhaseSpace& M = scene.phase_space();
    const std::string source = peers::rhs_c_source(scene.pi.hamiltonian_vector_field(scene.H), M.coordinate_vars(),
                                                   M.coordinates(), "free rigid body */ injected");
    // H = x1^2/4 + x2^2/2 + 3/4 x3^2: dx1/dt = {x1, H} = -x3 * x2 + x2 * 3/2 x3 = 1/2 x2 x3 (shortest digits: 0.5)
    CHECK(source.find("const double v_x1 = y[0];") != std::string::npos);
    CHECK(source.find("f[0] = 0.5*v_x2*v_x3;") != std::string::npos);
    CHECK(source.find("dfdy[8] = 0.0;") != std::string::npos);  // d(dx3/dt)/dx3
    CHECK(source.find("*/ injected") == std::string::npos);     // the title cannot end the comment
    // the field alone, for the explicit peers: no Jacobian in the source or the library
    const std::string field_only = peers::rhs_c_source(scene.pi.hamiltonian_vector_field(scene.H), M.coordinate_vars(),
                                                       M.coordinates(), scene.name, /*jacobian=*/false);
    CHECK(field_only.find("pgi_peer_jacobian") == std::string::npos);
    const peers::CompiledRhs rhs = peers::compile_rhs(field_only, M.dim());
    CHECK(!rhs.jacobian);
    const double x[3] = {0.6, 0.8, 0.3};
    double f[3];
    REQUIRE(bool(rhs.rhs));
    CHECK(rhs.rhs(0, x, f, nullptr) == 0);
    CHECK(f[0] == 0.5 * 0.8 * 0.3);
}

TEST_CASE("peers' right-hand side: a compiler that fails is an error naming it") {
    const Scene scene = load_scene(fs::path(PGI_SCENES_DIR) / "rigid_body.toml");
    const PhaseSpace& M = scene.phase_space();
    peers::RhsCompileOptions options;
    options.compiler = {"false"};
    try {
        peers::compile_rhs(scene.pi.hamiltonian_vector_field(scene.H), M.coordinate_vars(), M.coordinates(), scene.name,
                           options);
        FAIL("no error");
    } catch (const NativeCodeError& e) {
        CHECK(std::string(e.what()).find("the compiler `false -O3 -march=native -fPIC -shared` exited with status 1") !=
              std::string::npos);
    }
    options.compiler = {"/nonexistent/cc"};
    CHECK_THROWS_AS(peers::compile_rhs(scene.pi.hamiltonian_vector_field(scene.H), M.coordinate_vars(), M.coordinates(),
                                       scene.name, options),
                    NativeCodeError);
}
