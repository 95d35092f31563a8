#pragma once
// Native code for compiled maps (docs/math.md 6, "Native code"): a CompiledMap's tape written out as
// straight-line C++, built by the system C++ compiler into a shared library, loaded, and attached to the map,
// whose eval() then runs it. The JIT of heyoka, with the system compiler in LLVM's place: the interpreter's
// index loads and loop control disappear (2-2.5x on the step's maps at k = 10), while every output is formed
// by the interpreter's operations in the interpreter's order (the same monomial products, the same four
// partial sums and their pairing; the library and the generated code are compiled with -ffp-contract=off), so
// a native map's outputs are the interpreter's, bit for bit, and every contract that holds for one holds for
// the other (the batch step's lanes equal the single step, for instance). The code holds a map's structure, not its
// coefficients, which it reads from the map at run time (CompiledMap::NativeEval): a library built once serves the
// same maps at every dt a stepper is planned for, and is kept and found under that structure.
#include "series/compile.hpp"

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pgi {

/// The compiler could not be run, failed, timed out, or its library could not be loaded: what() names which,
/// with the command and the compiler's last lines of output.
class NativeCodeError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// How a group of four outputs is written: AVX2's four lanes or SSE2's two pairs, as the interpreter sums them
/// (GroupVectors, series/compile.hpp). Either gives the interpreter's bits. automatic: AVX2 where the processor running
/// pgi has it (the library is built for and loaded on it) and it saves a tenth of the map's operations or more, map by
/// map as the interpreter decides (CompiledMap::fours_pay); a map written in fours carries AVX2 as its functions'
/// target.
using NativeVectors = GroupVectors;

struct NativeOptions {
    /// The compiler's command: empty means $PGI_CXX, else $CXX, else "c++" (its first word searched on PATH), split
    /// into words as the shell splits them but without command substitution (`ccache g++`, `g++-12 -march=native`).
    /// Called as `compiler... -O2 -ffp-contract=off -fPIC -shared -nostdlib -fno-stack-protector -w -o LIB SOURCE`
    /// (the code calls no library: nothing to link, nothing to load beside it).
    std::string compiler;
    NativeVectors vectors = NativeVectors::automatic;
    /// Where built libraries are kept, keyed by a hash of their source and command (a later build of the same maps
    /// loads the kept library instead of compiling): empty means $PGI_JIT_CACHE, else $XDG_CACHE_HOME/pgi/jit, else
    /// $HOME/.cache/pgi/jit, else $TMPDIR/pgi-jit-EUID. Missing directories are created 0700. The directory must be
    /// owned by the effective user, not writable by group or others and not a symbolic link; one named here or by
    /// $PGI_JIT_CACHE that fails this is a NativeCodeError saying why, of the defaults the first that passes is used.
    /// A kept library is loaded only if its source matches and its SHA-256 is the one pgi wrote beside it (KEY.hash).
    std::string cache_dir;
    /// After a library is added, the temporaries of builds killed before they ended (older than timeout and a minute)
    /// are removed, then the oldest kept libraries (by last write) while they hold more than this; only pgi's own names
    /// (KEY.cpp, KEY.so, KEY.hash, KEY.PID-N.EXT, KEY 16 hex digits) are looked at, never another file (a library
    /// loaded by a running process stays mapped: only its name goes).
    std::uintmax_t cache_limit_bytes = std::uintmax_t(256) << 20;
    /// The compiler's process group is killed past this (series/detail/child_process.hpp).
    std::chrono::seconds timeout{300};
    /// The terms and monomials compiled at most, over all maps (those already native, from the cache, counted): the
    /// maps are taken in the order given while they fit, the rest stay interpreted (the compiler's time grows with
    /// the source: 0.1-0.3 s per thousand here).
    std::size_t max_size = 6000;
    /// A map of more terms and monomials than this stays interpreted (its code, about 20 bytes a term, would crowd
    /// the instruction cache). Measured with native code for every map below it (pgi_bench_step --jit, two runs each):
    /// Lotka-Volterra's grad and Hess S_dt at k = 16, dt = 0.2 (1020 terms) and k = 14, dt = 0.4 (1310) native take
    /// the step from 870 to 548 ns and from 1360 to 905 ns; the rigid body's and Henon-Heiles' steps unchanged.
    std::size_t max_map_size = 3000;
};

/// Whether a step's compiled maps run native code (StepOptions::native); the choice never changes a number, since
/// native code gives the interpreter's bits.
enum class NativePolicy {
    /// Native code the cache already keeps is attached at once (attach_kept_native_code), machine code written in
    /// memory for the other maps (series/machine_code.hpp); a step that has run long enough for a build to pay builds
    /// native code in the background (NativeBuild) and switches to it when it is ready.
    automatic,
    always,  ///< built before the first step (attach_native_code; NativeCodeError if it cannot be), machine code for
             ///< the maps it leaves out
    never,   ///< interpreted (no machine code either)
};
std::string to_string(NativePolicy p);

/// The C++ source of map's evaluator, a translation unit of its own: extern "C" void symbol(const double* in, const
/// double* term_coeff, const double* group_coeff, double* out) (CompiledMap::NativeEval), the interpreter's operations
/// in its order (CompiledMap::eval_with and the lane rows of split_sums).
std::string native_source(const CompiledMap& map, const std::string& symbol,
                          NativeVectors vectors = NativeVectors::automatic);

/// How many of maps run native code now.
std::size_t native_count(const std::vector<CompiledMap*>& maps);

/// The maps attach_native_code would compile now (their indices): those not native yet, in the order given, while
/// they fit in max_size with the native ones counted first, each of at most max_map_size.
std::vector<std::size_t> native_candidates(const std::vector<CompiledMap*>& maps, const NativeOptions& options = {});

/// Builds native code for the maps and attaches it, the maps in the order given (the most used first) while they fit
/// in max_size: each map a library of its own (its source, one compiler call, or none when the cache keeps it), so that
/// a map found again in another step (the same S_dt's maps beside a predictor of another order, at another dt) finds
/// its library. Skips maps already native and empty ones. Returns how many maps run native code afterwards. Throws
/// NativeCodeError (the maps then stay interpreted).
std::size_t attach_native_code(const std::vector<CompiledMap*>& maps, const NativeOptions& options = {});

/// attach_native_code without a compiler: attaches the libraries the cache keeps for these maps, those it keeps (the
/// same checks as attach_native_code's). Returns how many maps run native code afterwards. Never throws: without a
/// usable cache or a kept library the maps stay as they were.
std::size_t attach_kept_native_code(const std::vector<CompiledMap*>& maps, const NativeOptions& options = {});

/// attach_native_code on a thread of its own, as a JIT's second tier compiles hot code while the interpreter goes on:
/// the libraries of the maps (attach_native_code's choice and sources) are built or found while the caller keeps
/// evaluating them interpreted; attach() then gives the maps, or any copy of them, their native code. The destructor
/// cancels a build still running (its compiler's group is killed) and waits for its thread.
class NativeBuild {
public:
    /// Starts the build of maps' libraries (the maps are read here, not kept). Throws only std::system_error (no
    /// thread); the build's own failures are kept (failure()).
    explicit NativeBuild(const std::vector<CompiledMap*>& maps, const NativeOptions& options = {});
    NativeBuild(const NativeBuild&) = delete;
    NativeBuild& operator=(const NativeBuild&) = delete;
    ~NativeBuild();
    /// The build has ended, successfully or not (then attach() does not wait).
    bool done() const;
    /// Returns once done() (from any thread).
    void wait() const;
    /// Once done and built: attaches each planned map's native code in maps (the maps the build was started from,
    /// or maps in the same order, each given its library only if it has the planned structure: its source is the
    /// planned one) and returns how many of maps run native code; before that, or
    /// after a failure, nothing is attached and the count is of those native already (kept from the cache).
    std::size_t attach(const std::vector<CompiledMap*>& maps) const;
    /// Why the build failed: "" while it runs and after a success.
    std::string failure() const;

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace pgi
