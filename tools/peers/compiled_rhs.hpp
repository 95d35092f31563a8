#pragma once
// The peers' own right-hand side (issue 33): pi grad H and its Jacobian as a GSL user writes them, in C, generated
// from the scene's exact polynomials, compiled by the system C compiler as a user compiles it (cc -O3 -march=native)
// into a shared library in a private temporary directory, and loaded. GSL's steppers then call these functions
// directly and Boost.Odeint's through a function pointer: no pgi code runs in a peer's loop.
#include "series/poly.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pgi::peers {

/// GSL's signatures (gsl_odeiv2_system's function and jacobian): f = dy/dt at y; dfdy row-major n x n, dfdt = 0.
using RhsFunction = int (*)(double t, const double y[], double f[], void* params);
using JacobianFunction = int (*)(double t, const double y[], double* dfdy, double dfdt[], void* params);

/// The C source of the peers' right-hand side: int pgi_peer_rhs(...) and int pgi_peer_jacobian(...) with GSL's
/// signatures, for the vector field `field` over the ring variables `vars` named `names` (one output per variable; a
/// term in any other variable is a std::invalid_argument). Each
/// coordinate is read once into a local (v_NAME), each output is its polynomial written out term by term (the double
/// nearest to each exact coefficient, shortest round-trip digits; a power as repeated products), and the Jacobian's
/// entries are the exact derivatives (written where they are not zero, the rest set to zero first, from 9 variables
/// on). Without jacobian, only pgi_peer_rhs (what the explicit peers call: the compiler's time is the Jacobian's for
/// the most part on large systems, 8.5 of 11 s on a 1000-site lattice). title goes into the leading comment only.
std::string rhs_c_source(const std::vector<Poly>& field, const std::vector<std::size_t>& vars,
                         const std::vector<std::string>& names, const std::string& title, bool jacobian = true);

/// The compiler's command: $CC split at blanks (no shell), else "cc", followed by flags (default -O3 -march=native:
/// what a user asks of the compiler for a right-hand side) and "-fPIC -shared -o LIB SOURCE".
struct RhsCompileOptions {
    std::vector<std::string> compiler;  // empty: $CC, else cc
    std::vector<std::string> flags{"-O3", "-march=native"};
};

/// The source, compiled and loaded. Copies share the library, which stays loaded while one of them lives.
struct CompiledRhs {
    RhsFunction rhs = nullptr;
    JacobianFunction jacobian = nullptr;  // null when the source has none
    std::size_t n = 0;
    std::string source;
    std::string command;       // the compiler's command, as run (the files' paths left out)
    double build_seconds = 0;  // writing, compiling and loading
    std::shared_ptr<void> library;
};

/// Writes source into a private directory (mkdtemp under $TMPDIR or /tmp, 0700), runs the compiler on it through
/// run_child (no shell, its own process group, a time-out), loads the library (RTLD_NOW | RTLD_LOCAL), finds
/// pgi_peer_rhs and pgi_peer_jacobian if the source has it, and removes the files and the directory (the library stays
/// mapped). Throws NativeCodeError (series/native.hpp: pgi_peers exits 7, as pgi does when native code cannot be built)
/// naming the command and the compiler's last lines when it cannot be run, fails, or what it wrote cannot be loaded.
CompiledRhs compile_rhs(const std::string& source, std::size_t n, const RhsCompileOptions& options = {});

/// rhs_c_source then compile_rhs.
CompiledRhs compile_rhs(const std::vector<Poly>& field, const std::vector<std::size_t>& vars,
                        const std::vector<std::string>& names, const std::string& title,
                        const RhsCompileOptions& options = {}, bool jacobian = true);

}  // namespace pgi::peers
