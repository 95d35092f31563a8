// Native code for compiled maps (series/native.hpp): the same bits as the interpreter on random maps (rows,
// groups, signed zeros, overflow), the step with jit the same trajectory as without, a failing compiler a
// NativeCodeError that leaves the maps interpreted, and a kept library loaded instead of compiled again.
#include "series/native.hpp"
#include "series/poly.hpp"
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>

#include <sys/stat.h>
#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;

namespace {

std::uint64_t bits(double v) {
    return std::bit_cast<std::uint64_t>(v);
}

// A fresh directory for this process's kept libraries (so no test reads another run's).
NativeOptions test_options(const std::string& name) {
    NativeOptions o;
    o.cache_dir = (fs::temp_directory_path() / ("pgi-native-test-" + std::to_string(::getpid()) + "-" + name)).string();
    fs::remove_all(o.cache_dir);
    return o;
}

// The NativeCodeError that attaching map's native code with o raises (a test failure if there is none); the map stays
// interpreted and nothing is left half-written in the cache directory, which is then removed.
std::string native_code_error(CompiledMap& map, const NativeOptions& o) {
    std::string what;
    try {
        attach_native_code({&map}, o);
        FAIL("no error");
    } catch (const NativeCodeError& e) {
        what = e.what();
    }
    CHECK_FALSE(map.native());
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(o.cache_dir, ec)) FAIL("left behind: " << e.path());
    fs::remove_all(o.cache_dir);
    return what;
}

}  // namespace

TEST_CASE(
    "native: every output is the interpreter's, bit for bit, on random maps with rows and groups, in SSE2 and AVX2 "
    "code, and each map's width its own") {
    const auto r = make_ring({"unused", "a", "b", "c"});
    for (const NativeVectors vectors : {NativeVectors::sse2, NativeVectors::avx2, NativeVectors::automatic}) {
        CAPTURE(static_cast<int>(vectors));
        if (vectors == NativeVectors::avx2 && !__builtin_cpu_supports("avx2")) {
            MESSAGE("this processor has no AVX2: its code is not run");
            continue;
        }
        std::mt19937 gen(21);
        std::uniform_real_distribution<double> input(-2.0, 2.0);
        std::vector<CompiledMap> maps;
        for (int trial = 0; trial < 4; ++trial)
            maps.push_back(CompiledMap::build(test::mixed_outputs(r, gen), {3, 1, 2}));
        std::vector<Poly> rows = test::mixed_outputs(r, gen);
        rows.erase(rows.begin() + 7, rows.end());  // the outputs before the group: rows only, so fours save nothing
        maps.push_back(CompiledMap::build(rows, {3, 1, 2}));
        REQUIRE(maps.front().fours_pay());
        REQUIRE_FALSE(maps.back().fours_pay());
        // each map's source is the one asked for, four lanes at once (AVX2 by its functions' target attribute) or
        // pairs; automatic decides map by map, as the interpreter does, so one library can hold both
        for (const CompiledMap& m : maps) {
            const std::string source = native_source(m, "f", vectors);
            const bool fours =
                vectors == NativeVectors::avx2 || (vectors == NativeVectors::automatic && m.groups_in_fours());
            CHECK((source.find("target(\"avx2\")") != std::string::npos) == fours);
            if (&m != &maps.back())
                CHECK((source.find("pgi_load4(gc") != std::string::npos) == fours);  // (the last has no group)
        }
        const std::vector<CompiledMap> interpreted = maps;
        std::vector<CompiledMap*> pointers;
        for (auto& m : maps) pointers.push_back(&m);
        NativeOptions options = test_options("random");
        options.vectors = vectors;
        REQUIRE(attach_native_code(pointers, options) == maps.size());
        // each map a library of its own, its source the one asked for (above: at its own width)
        std::set<std::string> kept;
        for (const auto& e : fs::directory_iterator(options.cache_dir))
            if (e.path().extension() == ".cpp") kept.insert(test::slurp(e.path()));
        CHECK(kept.size() == maps.size());
        for (std::size_t i = 0; i < maps.size(); ++i)
            CHECK(kept.count(native_source(interpreted[i], "pgi_map", vectors)));
        std::size_t compared = 0;
        for (std::size_t i = 0; i < maps.size(); ++i) {
            CHECK(maps[i].native());
            CHECK_FALSE(interpreted[i].native());
            const std::size_t O = maps[i].num_outputs();
            std::vector<double> a(O), b(O);
            for (int point = 0; point < 200; ++point) {
                double x[3] = {input(gen), input(gen), input(gen)};
                if (point == 1) x[0] = -0.0, x[1] = 0.0;  // signed zeros
                if (point == 2) x[2] = 1e120;             // overflowing monomials
                if (point == 3) x[1] = std::numeric_limits<double>::quiet_NaN();
                interpreted[i].eval(x, a.data());
                maps[i].eval(x, b.data());
                for (std::size_t o = 0; o < O; ++o) {
                    CAPTURE(i);
                    CAPTURE(point);
                    CAPTURE(o);
                    CHECK(bits(a[o]) == bits(b[o]));
                    ++compared;
                }
            }
        }
        CHECK(compared > 5000);
    }
}

TEST_CASE(
    "native: a map with parameters (slow inputs) gives the interpreter's bits at any of their values, one library for "
    "all, a coefficient that vanishes at some values and overflowing monomials included") {
    const auto r = make_ring({"unused", "a", "b", "c", "p", "q"});
    std::mt19937 gen(8);
    const std::vector<Poly> outputs = test::outputs_with_parameters(r, gen);
    const CompiledMap built = CompiledMap::build(outputs, {3, 1, 2, 4, 5}, 2);
    REQUIRE(built.num_slow_inputs() == 2);
    REQUIRE(built.tape().groups > 0);
    std::vector<CompiledMap> maps(2, built);
    const CompiledMap interpreted = built;
    // bound before the build to values where coefficients vanish or coincide: the structure is still the slots'
    std::vector<double> scratch(built.num_outputs());
    const double at_one[5] = {0.5, 0.5, 0.5, 1.0, 1.0}, elsewhere[5] = {0.5, 0.5, 0.5, 0.5, -1.5};
    maps[0].eval(at_one, scratch.data());
    maps[1].eval(elsewhere, scratch.data());
    NativeOptions options = test_options("parameters");
    REQUIRE(attach_native_code({&maps[0], &maps[1]}, options) == 2);
    std::size_t libraries = 0;  // the two copies have one structure: one source, one library
    for (const auto& e : fs::directory_iterator(options.cache_dir)) libraries += e.path().extension() == ".so";
    CHECK(libraries == 1);
    std::uniform_real_distribution<double> input(-2.0, 2.0);
    const std::size_t O = built.num_outputs();
    std::vector<double> a(O), b(O);
    std::size_t compared = 0, non_finite = 0;
    for (const auto& [pv, qv] :
         {std::pair{0.5, -1.5}, std::pair{1.0, 0.25}, std::pair{4.0, 2.0}, std::pair{1.0, 1.0}}) {
        for (int point = 0; point < 100; ++point) {
            double x[5] = {input(gen), input(gen), input(gen), pv, qv};
            if (point == 1) x[0] = -0.0, x[1] = 0.0;  // signed zeros
            if (point == 2) x[2] = 1e120;             // overflowing monomials, times coefficients that vanish
            interpreted.eval(x, a.data());
            maps[point % 2].eval(x, b.data());
            for (std::size_t o = 0; o < O; ++o) {
                CAPTURE(pv);
                CAPTURE(point);
                CAPTURE(o);
                CHECK(bits(a[o]) == bits(b[o]));
                non_finite += !std::isfinite(a[o]);
                ++compared;
            }
        }
    }
    CHECK(maps[0].native());
    CHECK(non_finite > 0);
    CHECK(compared > 3000);
    fs::remove_all(options.cache_dir);
}

TEST_CASE("native: a copy shares the loaded code; a kept library is loaded, not compiled again") {
    const auto r = make_ring({"x", "y"});
    const Poly f = pow(Poly::gen(r, 0), 3) - Poly::constant(r, Rational(1, 3)) * Poly::gen(r, 1);
    const NativeOptions options = test_options("cache");
    CompiledMap first = CompiledMap::build({f}, {0, 1});
    REQUIRE(attach_native_code({&first}, options) == 1);
    std::vector<fs::path> kept;
    for (const auto& e : fs::directory_iterator(options.cache_dir)) kept.push_back(e.path());
    REQUIRE(kept.size() == 3);  // the source, its library and its digest, nothing left over
    const auto written = fs::last_write_time(kept[0]);
    // the same map again, with a "compiler" that would fail if it were run: the kept library serves
    CompiledMap second = CompiledMap::build({f}, {0, 1});
    NativeOptions no_compiler = options;
    no_compiler.compiler = "c++";  // the same command as the first build (the key includes it) ...
    CHECK(attach_native_code({&second}, no_compiler) == 1);
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(options.cache_dir)) ++files;
    CHECK(files == 3);
    CHECK(fs::last_write_time(kept[0]) == written);
    const CompiledMap copy = second;
    const double x[2] = {0.5, 3};
    double y = 0;
    copy.eval(x, &y);
    CHECK(copy.native());
    CHECK(y == 0.125 - 1.0);
    fs::remove_all(options.cache_dir);
}

TEST_CASE("native: a compiler that fails or does not exist is a NativeCodeError naming it; the maps stay interpreted") {
    const auto r = make_ring({"x"});
    CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    for (const std::string compiler : {"false", "/nonexistent/pgi-cc"}) {
        CAPTURE(compiler);
        NativeOptions o = test_options("failing");
        o.compiler = compiler;
        CHECK(native_code_error(map, o).find(compiler) != std::string::npos);
    }
    const double x = 3;
    double y = 0;
    map.eval(&x, &y);
    CHECK(y == 9);
}

TEST_CASE("native: the compiler's command is split into words as the shell splits them, command substitution refused") {
    const auto r = make_ring({"x"});
    {
        CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
        NativeOptions o = test_options("words");
        o.compiler = "c++ -DPGI_UNUSED='a b'";  // a program and an argument with a quoted space
        REQUIRE(attach_native_code({&map}, o) == 1);
        const double x = 3;
        double y = 0;
        map.eval(&x, &y);
        CHECK(y == 9);
        fs::remove_all(o.cache_dir);
    }
    for (const auto& [compiler_, why] : {std::pair<std::string, std::string>{"c++ $(echo -O0)", "command substitution"},
                                         {"c++ 'unbalanced", "syntax"},
                                         {"c++ ; rm -rf /", "unquoted"},
                                         {"  ", "no words"}}) {
        const std::string& compiler = compiler_;  // (a name, not a binding: CAPTURE is a lambda)
        CAPTURE(compiler);
        CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
        NativeOptions o = test_options("bad-words");
        o.compiler = compiler;
        const std::string what = native_code_error(map, o);
        CHECK_MESSAGE(what.find("`" + compiler + "`") != std::string::npos, what);
        CHECK_MESSAGE(what.find(why) != std::string::npos, what);
    }
}

TEST_CASE(
    "native: the temporaries of a build killed before it ended are removed once stale, a running build's are not, even "
    "past the size bound") {
    const auto r = make_ring({"x"});
    CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 4)}, {0});
    NativeOptions o = test_options("stale");
    o.timeout = std::chrono::seconds(60);
    o.cache_limit_bytes = 1;  // the size bound takes every kept library but the new one, and no running build's file
    fs::create_directories(o.cache_dir);
    const fs::path stale = fs::path(o.cache_dir) / "0123456789abcdef.1-2.cpp",
                   running = fs::path(o.cache_dir) / "0123456789abcdef.3-4.so";
    std::ofstream(stale) << "killed";
    std::ofstream(running) << "being written";
    fs::last_write_time(stale,
                        fs::file_time_type::clock::now() - std::chrono::minutes(3));  // older than 60 s and a minute
    REQUIRE(attach_native_code({&map}, o) == 1);
    CHECK_FALSE(fs::exists(stale));
    CHECK(fs::exists(running));
    fs::remove_all(o.cache_dir);
}

TEST_CASE(
    "native: one library serves every map of the same structure, each with its own coefficients, bit for bit; another "
    "zero pattern builds its own") {
    const auto r = make_ring({"unused", "a", "b", "c"});
    std::mt19937 gen(5);
    const std::vector<Poly> base = test::mixed_outputs(r, gen);
    // the same monomials with other coefficients (a scale per output, as another dt scales S_j): the same structure
    std::vector<Poly> scaled = base, zeroed = base;
    for (std::size_t o = 0; o < scaled.size(); ++o) scaled[o] = Poly::constant(r, Rational(long(o) - 5, 7)) * base[o];
    scaled[5] = base[5];  // (o = 5 would scale by zero: another structure)
    zeroed[4] = Poly(r);  // one output fewer
    const NativeOptions options = test_options("structure");
    CompiledMap first = CompiledMap::build(base, {3, 1, 2});
    REQUIRE(attach_native_code({&first}, options) == 1);
    const auto files = [&] {
        std::size_t n = 0;
        for ([[maybe_unused]] const auto& e : fs::directory_iterator(options.cache_dir)) ++n;
        return n;
    };
    REQUIRE(files() == 3);
    CompiledMap second = CompiledMap::build(scaled, {3, 1, 2}), third = CompiledMap::build(zeroed, {3, 1, 2});
    const CompiledMap second_interpreted = second, third_interpreted = third;
    NativeOptions kept_only = options;
    CHECK(attach_kept_native_code({&second}, kept_only) == 1);  // found, not compiled
    CHECK(files() == 3);
    CHECK(attach_kept_native_code({&third}, kept_only) == 0);  // another structure: nothing kept for it
    REQUIRE(attach_native_code({&third}, options) == 1);
    CHECK(files() == 6);
    std::uniform_real_distribution<double> input(-2.0, 2.0);
    for (int point = 0; point < 100; ++point) {
        const double x[3] = {input(gen), input(gen), input(gen)};
        for (const auto& [native, interpreted] :
             {std::pair{&second, &second_interpreted}, std::pair{&third, &third_interpreted}}) {
            std::vector<double> a(native->num_outputs()), b(native->num_outputs());
            native->eval(x, a.data());
            interpreted->eval(x, b.data());
            for (std::size_t o = 0; o < a.size(); ++o) REQUIRE(bits(a[o]) == bits(b[o]));
        }
    }
    fs::remove_all(options.cache_dir);
}

TEST_CASE("native: the step with jit takes the interpreted step's trajectory bit for bit, on every bundled scene") {
    const std::string cache = test_options("steps").cache_dir;
    ::setenv("PGI_JIT_CACHE", cache.c_str(), 1);
    for (const std::string& name : test::bundled_names()) {
        CAPTURE(name);
        const Scene s = test::bundled(name);
        if (!s.x0) continue;
        const Eigen::VectorXd x0 = Eigen::Map<const Eigen::VectorXd>(s.x0->data(), Eigen::Index(s.x0->size()));
        StepOptions opt;
        opt.k = s.scheme->order();
        opt.dt = s.dt;
        opt.realisation = s.scheme->realisation_choice();
        opt.native = NativePolicy::never;
        NewtonStepper interpreted = s.scheme->stepper(opt, x0);
        opt.native = NativePolicy::always;
        NewtonStepper native = s.scheme->stepper(opt, x0);
        CHECK(interpreted.info().native_maps == 0);
        CHECK(native.info().native_maps > 0);  // every scene has at least S_dt's maps
        Eigen::VectorXd x = x0, y = x0, dx(x0.size()), dy(x0.size());
        for (int n = 0; n < 50; ++n) {
            const double dt = n % 5 == 4 ? 0.6 * s.dt : s.dt;  // the planned map, and the stacked one with Horner
            REQUIRE(interpreted.step(x, dt, dx) == native.step(y, dt, dy));
            x += dx, y += dy;
            for (Eigen::Index i = 0; i < x.size(); ++i) REQUIRE(bits(x[i]) == bits(y[i]));
        }
    }
    ::unsetenv("PGI_JIT_CACHE");
    fs::remove_all(cache);
}

TEST_CASE(
    "native: a map written in pieces (above 2000 terms and monomials, past the default limit) keeps the interpreter's "
    "bits") {
    const auto r = make_ring({"a", "b", "c", "d"});
    std::mt19937 gen(8);
    std::uniform_int_distribution<long> coeff(-99, 99);
    std::uniform_int_distribution<unsigned long> ex(0, 6);
    std::vector<Poly> outputs;
    for (int o = 0; o < 7; ++o) {
        Poly f(r);
        for (int t = 0; t < 500; ++t) {
            Poly m = Poly::constant(r, Rational(coeff(gen), 7));
            for (std::size_t v = 0; v < 4; ++v) m = m * pow(Poly::gen(r, v), ex(gen));
            f += m;
        }
        outputs.push_back(f);
    }
    CompiledMap map = CompiledMap::build(outputs, {0, 1, 2, 3});
    const CompiledMap interpreted = map;
    REQUIRE(map.num_terms() + map.num_monomials() > 2000);
    NativeOptions o = test_options("pieces");
    REQUIRE(map.num_terms() + map.num_monomials() > o.max_map_size);
    CHECK(attach_native_code({&map}, o) == 0);  // above the default limits: interpreted
    o.max_map_size = o.max_size = 100000;
    REQUIRE(attach_native_code({&map}, o) == 1);
    CHECK(native_source(map, "f").find("noinline") != std::string::npos);  // in pieces
    std::uniform_real_distribution<double> input(-1.5, 1.5);
    std::vector<double> a(outputs.size()), b(outputs.size());
    for (int point = 0; point < 100; ++point) {
        const double x[4] = {input(gen), input(gen), input(gen), input(gen)};
        interpreted.eval(x, a.data());
        map.eval(x, b.data());
        for (std::size_t i = 0; i < a.size(); ++i) CHECK(bits(a[i]) == bits(b[i]));
    }
    fs::remove_all(o.cache_dir);
}

TEST_CASE("native: past the cache's limit the oldest kept libraries go, the newest stays") {
    const auto r = make_ring({"x"});
    NativeOptions o = test_options("limit");
    CompiledMap first = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    REQUIRE(attach_native_code({&first}, o) == 1);
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(o.cache_dir)) ++files;
    REQUIRE(files == 3);
    o.cache_limit_bytes = 1;  // below any library: every older one goes
    CompiledMap second = CompiledMap::build({pow(Poly::gen(r, 0), 3)}, {0});
    REQUIRE(attach_native_code({&second}, o) == 1);
    std::vector<fs::path> kept;
    for (const auto& e : fs::directory_iterator(o.cache_dir)) kept.push_back(e.path());
    REQUIRE(kept.size() == 3);  // the second map's source, library and digest only
    CHECK(kept[0].stem() == kept[1].stem());
    CHECK(kept[1].stem() == kept[2].stem());
    const double x = 2;
    double y1 = 0, y2 = 0;
    first.eval(&x, &y1);  // still loaded, though its file is gone
    second.eval(&x, &y2);
    CHECK(y1 == 4);
    CHECK(y2 == 8);
    fs::remove_all(o.cache_dir);
}

TEST_CASE(
    "native: a cache directory named by PGI_JIT_CACHE that cannot be used is an error naming it, not a silent "
    "fallback") {
    const auto r = make_ring({"x"});
    CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    const fs::path file = fs::temp_directory_path() / ("pgi-native-test-file-" + std::to_string(::getpid()));
    std::ofstream(file) << "not a directory";
    ::setenv("PGI_JIT_CACHE", (file / "jit").c_str(), 1);  // under a regular file: cannot be created
    try {
        attach_native_code({&map});
        FAIL("no error");
    } catch (const NativeCodeError& e) {
        CHECK(std::string(e.what()).find(file.string()) != std::string::npos);
    }
    ::unsetenv("PGI_JIT_CACHE");
    CHECK_FALSE(map.native());
    CHECK(fs::file_size(file) == std::string("not a directory").size());  // untouched
    fs::remove(file);
}

namespace {

// A shell script standing in for the compiler (NativeOptions::compiler): body runs with $out the library it is asked
// to write and $src the source.
std::string fake_compiler(const fs::path& dir, const std::string& name, const std::string& body) {
    fs::create_directories(dir);
    const fs::path p = dir / name;
    std::ofstream(p) << "#!/bin/sh\nwhile [ $# -gt 1 ]; do [ \"$1\" = -o ] && out=$2; shift; done\nsrc=$1\n"
                     << body << "\n";
    fs::permissions(p, fs::perms::owner_all);
    return p.string();
}

// A fresh directory for the fake compilers and planted files of one test, removed with them.
struct Scratch {
    fs::path path;
    explicit Scratch(const std::string& name)
        : path(fs::temp_directory_path() / ("pgi-native-scratch-" + std::to_string(::getpid()) + "-" + name)) {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~Scratch() { fs::remove_all(path); }
};

std::vector<std::string> names_in(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

}  // namespace

TEST_CASE("native: a compiler that exits 0 without a usable library is refused before anything enters the cache") {
    // each once left its output in the cache under the kept name, and every later run failed until it was cleaned
    const Scratch scratch("bad-compilers");
    const auto r = make_ring({"x"});
    for (const auto& [body_, why] :
         {std::pair<std::string, std::string>{"exit 0", "wrote no library"},
          {"echo garbage > \"$out\"", "not a loadable library"},
          {"echo 'int unrelated;' | c++ -shared -fPIC -x c++ - -o \"$out\"", "without the function pgi_map"}}) {
        const std::string& body = body_;  // (a name, not a binding: CAPTURE is a lambda)
        CAPTURE(body);
        CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
        NativeOptions o = test_options("bad-compiler");
        o.compiler = fake_compiler(scratch.path, "cc", body);
        const std::string what = native_code_error(map, o);  // (also checks the cache is left empty)
        CHECK_MESSAGE(what.find(why) != std::string::npos, what);
        // the real compiler afterwards, in the same directory, builds and loads
        o.compiler.clear();
        REQUIRE(attach_native_code({&map}, o) == 1);
        fs::remove_all(o.cache_dir);
    }
}

TEST_CASE("native: the compiler's diagnostics become one bounded line, terminal codes and NULs shown as \\xNN") {
    const Scratch scratch("noisy");
    const auto r = make_ring({"x"});
    CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    NativeOptions o = test_options("noisy");
    // 100 MB of diagnostics, an escape sequence and a NUL at the end
    o.compiler = fake_compiler(scratch.path, "cc",
                               "head -c 100000000 /dev/zero | tr '\\000' 'x'\nprintf '\\nerror: \\033[31mred\\000 "
                               "after a NUL\\033[0m\\n' >&2\nexit 1");
    const std::string what = native_code_error(map, o);
    CHECK(what.size() < 2000);
    CHECK(what.find('\x1b') == std::string::npos);
    CHECK(what.find('\n') == std::string::npos);
    CHECK_MESSAGE(what.find("error: \\x1b[31mred\\x00 after a NUL\\x1b[0m") != std::string::npos, what);
    CHECK(what.find("exited with status 1") != std::string::npos);
}

TEST_CASE("native: a library planted under a kept name, without pgi's digest or with another's, is never loaded") {
    const Scratch scratch("planted");
    const auto r = make_ring({"x"});
    NativeOptions o = test_options("planted");
    CompiledMap first = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    REQUIRE(attach_native_code({&first}, o) == 1);
    std::string key;
    for (const std::string& name : names_in(o.cache_dir))
        if (name.size() > 3 && name.substr(name.size() - 3) == ".so") key = name.substr(0, name.size() - 3);
    REQUIRE(key.size() == 16);
    // a library with the right symbol whose constructor leaves a mark when it is loaded
    const fs::path marker = scratch.path / "LOADED", evil_source = scratch.path / "evil.cpp",
                   evil = scratch.path / "evil.so";
    std::ofstream(evil_source)
        << "#include <cstdio>\n__attribute__((constructor)) static void mark() { std::fopen(\"" << marker.string()
        << "\", \"w\"); }\nextern \"C\" void pgi_map_0(const double*, double* out) { out[0] = 666; }\n";
    REQUIRE(std::system(("c++ -shared -fPIC -o '" + evil.string() + "' '" + evil_source.string() + "'").c_str()) == 0);
    const fs::path library = fs::path(o.cache_dir) / (key + ".so"), digest = fs::path(o.cache_dir) / (key + ".hash");
    for (const bool keep_digest : {false, true}) {
        CAPTURE(keep_digest);
        // put in place by a rename, as a planter would (writing over it would change the library this process has
        // mapped)
        fs::copy_file(evil, library.string() + ".planting", fs::copy_options::overwrite_existing);
        fs::rename(library.string() + ".planting", library);  // pgi's digest (if kept) is the real library's
        if (!keep_digest) fs::remove(digest);
        CompiledMap again = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
        REQUIRE(attach_native_code({&again}, o) == 1);  // built anew instead
        const double x = 3;
        double y = 0;
        again.eval(&x, &y);
        CHECK(y == 9);
        CHECK_FALSE(fs::exists(marker));
        CHECK(fs::exists(digest));
    }
    fs::remove_all(o.cache_dir);
}

// A restored or merged cache may pair one key's source with another key's library and digest, which match each other.
TEST_CASE("native: a library and digest kept under another key are not loaded for this key's source") {
    const Scratch scratch("swapped");
    const auto r = make_ring({"x"});
    NativeOptions o = test_options("swapped");
    const auto keys = [&] {
        std::set<std::string> found;
        for (const std::string& name : names_in(o.cache_dir))
            if (name.size() > 3 && name.substr(name.size() - 3) == ".so") found.insert(name.substr(0, name.size() - 3));
        return found;
    };
    CompiledMap square = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    REQUIRE(attach_native_code({&square}, o) == 1);
    const std::string square_key = *keys().begin();
    CompiledMap cube = CompiledMap::build({pow(Poly::gen(r, 0), 3) + Poly::gen(r, 0)}, {0});
    REQUIRE(attach_native_code({&cube}, o) == 1);
    std::set<std::string> both = keys();
    REQUIRE(both.size() == 2);
    both.erase(square_key);
    const fs::path dir(o.cache_dir);
    for (const char* ext : {".so", ".hash"}) {  // the cube's pair under the square's key, by renames
        fs::copy_file(dir / (*both.begin() + ext), dir / (square_key + ext + ".swapping"));
        fs::rename(dir / (square_key + ext + ".swapping"), dir / (square_key + ext));
    }
    CompiledMap again = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    REQUIRE(attach_native_code({&again}, o) == 1);  // built anew
    const double x = 3;
    double y = 0;
    again.eval(&x, &y);
    CHECK(y == 9);
    fs::remove_all(o.cache_dir);
}

TEST_CASE("native: a cache directory others can write, a link, or another user's is refused, naming why") {
    const Scratch scratch("unsafe-dirs");
    const auto r = make_ring({"x"});
    const auto refused = [&](const fs::path& dir, const std::string& why) {
        CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
        NativeOptions o;
        o.cache_dir = dir.string();
        try {
            attach_native_code({&map}, o);
            FAIL("accepted " << dir);
        } catch (const NativeCodeError& e) {
            const std::string what = e.what();
            CHECK_MESSAGE(what.find(dir.string() + ": " + why) != std::string::npos, what);
        }
        CHECK(names_in(dir).empty());
    };
    fs::create_directories(scratch.path / "open");
    fs::permissions(scratch.path / "open", fs::perms::all);
    refused(scratch.path / "open", "it is writable by others (mode 0777");
    fs::create_directories(scratch.path / "group");
    fs::permissions(scratch.path / "group", fs::perms::owner_all | fs::perms::group_all);
    refused(scratch.path / "group", "it is writable by its group");
    fs::create_directories(scratch.path / "target");
    fs::create_directory_symlink(scratch.path / "target", scratch.path / "link");
    refused(scratch.path / "link", "it is a symbolic link");
    if (::geteuid() == 0) {
        fs::create_directories(scratch.path / "foreign");
        REQUIRE(::chown((scratch.path / "foreign").c_str(), 65534, 65534) == 0);
        fs::permissions(scratch.path / "foreign", fs::perms::owner_all);
        refused(scratch.path / "foreign", "it is owned by uid 65534, not by the effective user (uid 0)");
    } else {
        MESSAGE("not root: a directory of another user is tested by tools_child_process.cpp's unprivileged run only");
    }
}

TEST_CASE("native: under umask 000 the cache, its parents and its files are private") {
    const Scratch scratch("umask");
    const auto r = make_ring({"x"});
    CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), 2)}, {0});
    NativeOptions o;
    o.cache_dir = (scratch.path / "made" / "by" / "pgi").string();
    const mode_t previous = ::umask(0);
    const std::size_t attached = attach_native_code({&map}, o);
    ::umask(previous);
    REQUIRE(attached == 1);
    const auto mode = [](const fs::path& p) { return fs::status(p).permissions(); };
    for (const fs::path& d : {scratch.path / "made", scratch.path / "made" / "by", fs::path(o.cache_dir)})
        CHECK(mode(d) == fs::perms::owner_all);
    for (const auto& e : fs::directory_iterator(o.cache_dir)) {
        CAPTURE(e.path());
        CHECK(mode(e.path()) ==
              (e.path().extension() == ".so" ? fs::perms::owner_all : fs::perms::owner_read | fs::perms::owner_write));
    }
}

TEST_CASE("native: trimming the cache removes only pgi's own files, never the user's, whatever their names and sizes") {
    const auto r = make_ring({"x"});
    NativeOptions o = test_options("shared");
    fs::create_directories(o.cache_dir);
    fs::permissions(o.cache_dir, fs::perms::owner_all);
    const std::vector<std::string> user_files{
        "thesis.final.tex",     "data.2024.csv",           "notes.txt",          "big.bin",
        "0123456789abcdef.txt", "0123456789abcdef.old.so", "0123456789ABCDEF.so"};
    for (const std::string& name : user_files) {
        std::ofstream(fs::path(o.cache_dir) / name) << std::string(name == "big.bin" ? 3 << 20 : 10, 'u');
        fs::last_write_time(fs::path(o.cache_dir) / name, fs::file_time_type::clock::now() - std::chrono::hours(24));
    }
    o.cache_limit_bytes = 1;  // every kept library but the newest goes, and nothing else
    for (int power : {2, 3}) {
        CompiledMap map = CompiledMap::build({pow(Poly::gen(r, 0), power)}, {0});
        REQUIRE(attach_native_code({&map}, o) == 1);
    }
    for (const std::string& name : user_files) {
        CAPTURE(name);
        CHECK(fs::exists(fs::path(o.cache_dir) / name));
    }
    CHECK(names_in(o.cache_dir).size() == user_files.size() + 3);  // and the newest library's three files
    fs::remove_all(o.cache_dir);
}
