#include "series/native.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <wordexp.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

extern char** environ;

namespace pgi {

namespace fs = std::filesystem;

namespace {

// A coefficient as a C++ hexadecimal literal: the double itself, no decimal rounding in between.
std::string literal(double c) {
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%a", c);
    return buffer;
}

// The terms of an output the interpreter evaluates from its row (eval_with), each with the partial sum (0..3) it
// adds it to, in its order: the first L - L mod 4 terms round-robin, the rest into sum 0.
struct Term {
    int sum;
    std::uint32_t monomial;
    double coeff;
};
std::vector<Term> row_terms(const CompiledMap::Tape& tape, std::size_t o) {
    std::vector<Term> terms;
    const std::uint32_t start = tape.row_start[o], L = tape.row_start[o + 1] - start, rounds = L / 4 * 4;
    for (std::uint32_t i = 0; i < L; ++i) terms.push_back({i < rounds ? int(i % 4) : 0, tape.term_monomial[start + i], tape.term_coeff[start + i]});
    return terms;
}

std::string env_or(const char* name, const std::string& fallback) {
    const char* v = std::getenv(name);
    return v && *v ? std::string(v) : fallback;
}

std::string compiler_of(const NativeOptions& o) {
    if (!o.compiler.empty()) return o.compiler;
    return env_or("PGI_CXX", env_or("CXX", "c++"));
}

// The compiler's command split into words as the shell splits them (quotes, escapes, $VARIABLES; `ccache g++`,
// `g++-12 -march=native`), by wordexp(3) with command substitution refused: an error names the command.
std::vector<std::string> compiler_words(const std::string& command) {
    // NOTE: wordexp is not thread-safe (glibc: MT-Unsafe), and steppers may be built on several threads at once
    static std::mutex one_at_a_time;
    std::vector<std::string> words;
    int r = 0;
    {
        const std::lock_guard<std::mutex> lock(one_at_a_time);
        wordexp_t w{};
        r = ::wordexp(command.c_str(), &w, WRDE_NOCMD);
        if (r == 0) words.assign(w.we_wordv, w.we_wordv + w.we_wordc);
        if (r == 0 || r == WRDE_NOSPACE) ::wordfree(&w);
    }
    if (r != 0 || words.empty()) {
        const char* why = r == WRDE_CMDSUB ? "command substitution is not allowed"
                          : r == WRDE_BADCHAR ? "an unquoted | & ; < > ( ) { } or newline"
                          : r == WRDE_SYNTAX  ? "a syntax error (an unbalanced quote?)"
                          : r == 0            ? "no words"
                                              : "it cannot be split";
        throw NativeCodeError("native code: the compiler command `" + command + "` cannot be used: " + why);
    }
    return words;
}

// Whether a map is written four lanes at once: each map as the interpreter decides it (CompiledMap::set_group_vectors),
// automatic: where the processor has AVX2 and that saves a tenth of the map's operations or more; where it saves
// less, pairs are the faster (the rigid body's and Henon-Heiles' maps at k = 10, nearly all rows, took 2-5% longer
// on AVX2). Per map, not per library: a rarely run map (the stacked general-dt one of grad and Hess S_dt, 2801 terms
// at Henon-Heiles k = 16, dt = 0.8) once tipped the whole library to pairs, and its hot maps with it (853 -> 1100 ns
// a step).
bool wide(NativeVectors v, const CompiledMap& map) {
    if (v != NativeVectors::automatic) return v == NativeVectors::avx2;
    return processor_has_avx2() && map.fours_pay();
}

// The maps written in fours carry AVX2 as a target attribute of their functions (target_attribute): the library
// itself is built for the baseline.
std::vector<std::string> compiler_flags() { return {"-O2", "-ffp-contract=off", "-fPIC", "-shared", "-w"}; }

std::string target_attribute(bool wide) { return wide ? "__attribute__((target(\"avx2\"))) " : ""; }

// The directory kept libraries go to (NativeOptions::cache_dir), created if missing. One the caller names
// (cache_dir or $PGI_JIT_CACHE) is the only candidate: unusable, it is an error naming it, not a silent fallback.
fs::path cache_directory(const NativeOptions& o) {
    std::vector<fs::path> candidates;
    const char* named = std::getenv("PGI_JIT_CACHE");
    if (!o.cache_dir.empty()) {
        candidates.push_back(o.cache_dir);
    } else if (named && *named) {
        candidates.push_back(named);
    } else {
        if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) candidates.push_back(fs::path(d) / "pgi" / "jit");
        if (const char* d = std::getenv("HOME"); d && *d) candidates.push_back(fs::path(d) / ".cache" / "pgi" / "jit");
        std::error_code ec;
        const fs::path tmp = fs::temp_directory_path(ec);
        if (!ec) candidates.push_back(tmp / ("pgi-jit-" + std::to_string(::getuid())));
    }
    for (const fs::path& d : candidates) {
        std::error_code ec;
        fs::create_directories(d, ec);
        if (!ec && ::access(d.c_str(), W_OK | X_OK) == 0) return d;
    }
    std::string tried;
    for (const fs::path& d : candidates) tried += (tried.empty() ? "" : ", ") + d.string();
    throw NativeCodeError("native code: no writable directory for the compiled libraries (tried " + (tried.empty() ? "none" : tried) + ")");
}

// FNV-1a: the cache key of a source and its command (the kept source is compared in full before its library is used).
std::string key_of(const std::string& text) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
    char buffer[20];
    std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(h));
    return buffer;
}

std::string read_all(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

void write_all(const fs::path& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw NativeCodeError("native code: cannot write " + p.string());
}

std::string last_lines(const std::string& text, std::size_t n) {
    std::size_t pos = text.size();
    for (std::size_t i = 0; i <= n && pos > 0; ++i) pos = text.rfind('\n', pos - 1);
    return pos == std::string::npos ? text : text.substr(pos + 1);
}

// Runs argv (argv[0] searched on PATH) with its output to log, at most timeout; "" when it exits 0, else what happened.
std::string run(const std::vector<std::string>& argv, const fs::path& log, std::chrono::seconds timeout) {
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    pid_t pid = 0;
    const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) return "cannot be run (" + std::string(std::strerror(spawned)) + ")";
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    int status = 0;
    for (auto pause = std::chrono::milliseconds(2);; pause = std::min(2 * pause, std::chrono::milliseconds(50))) {
        const pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) break;
        if (r < 0 && errno != EINTR) return "lost (waitpid: " + std::string(std::strerror(errno)) + ")";
        if (std::chrono::steady_clock::now() > deadline) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return "stopped after " + std::to_string(timeout.count()) + " s";
        }
        std::this_thread::sleep_for(pause);
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return "";
    if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
    return "was killed by signal " + std::to_string(WTERMSIG(status));
}

// A name no other process picks: for files written and then renamed into place.
std::string unique_suffix() {
    std::random_device rd;
    return std::to_string(::getpid()) + "-" + std::to_string(rd());
}

// Removes the temporaries of killed builds (a running build's, younger, are neither removed nor counted), then the
// oldest kept sources and libraries (by last write, the pair of key spared) while they hold more than limit bytes.
// Best effort: a file another process removes first, or cannot be read, is passed over.
void trim_cache(const fs::path& dir, const std::string& key, std::uintmax_t limit, std::chrono::seconds timeout) {
    std::error_code ec;
    std::vector<std::pair<fs::file_time_type, fs::path>> files;
    std::uintmax_t total = 0;
    // a temporary (KEY.SUFFIX.cpp, .so, .log) older than a compiler is given is a build that was killed: it goes
    const auto stale = fs::file_time_type::clock::now() - timeout - std::chrono::minutes(1);
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::uintmax_t size = e.file_size(ec);
        if (ec) continue;
        const fs::file_time_type written = e.last_write_time(ec);
        if (ec) continue;
        if (e.path().stem().string().find('.') != std::string::npos) {  // a temporary: a running build's is left alone
            if (written < stale) fs::remove(e.path(), ec);
            continue;
        }
        total += size;
        if (e.path().stem() != key) files.push_back({written, e.path()});
    }
    std::sort(files.begin(), files.end());
    for (const auto& [time, path] : files) {
        if (total <= limit) break;
        const std::uintmax_t size = fs::file_size(path, ec);
        if (!ec && fs::remove(path, ec)) total -= size;
    }
}

// The library of source in dir: the kept one if its source is the same, else compiled now (written under a temporary
// name, then renamed into place: a concurrent build of the same source writes the same bytes).
fs::path library_for(const std::string& source, const NativeOptions& o) {
    const std::string compiler = compiler_of(o);
    const std::vector<std::string> flags = compiler_flags();
    std::vector<std::string> argv = compiler_words(compiler);
    argv.insert(argv.end(), flags.begin(), flags.end());
    std::string command;
    for (const std::string& word : argv) command += (command.empty() ? "" : " ") + word;
    const fs::path dir = cache_directory(o);
    const std::string key = key_of(command + "\n" + source);
    const fs::path kept_source = dir / (key + ".cpp"), library = dir / (key + ".so");
    std::error_code ec;
    if (fs::exists(library, ec) && fs::exists(kept_source, ec) && read_all(kept_source) == source) return library;
    const std::string tmp = unique_suffix();
    const fs::path src = dir / (key + "." + tmp + ".cpp"), lib = dir / (key + "." + tmp + ".so"), log = dir / (key + "." + tmp + ".log");
    write_all(src, source);
    argv.insert(argv.end(), {"-o", lib.string(), src.string()});
    const std::string failure = run(argv, log, o.timeout);
    const std::string output = read_all(log);
    fs::remove(log, ec);
    if (!failure.empty()) {
        fs::remove(src, ec), fs::remove(lib, ec);
        throw NativeCodeError("native code: the compiler `" + command + "` " + failure + (output.empty() ? "" : ":\n" + last_lines(output, 10)));
    }
    fs::rename(lib, library, ec);
    if (!ec) fs::rename(src, kept_source, ec);
    if (ec) {
        fs::remove(src, ec), fs::remove(lib, ec);
        throw NativeCodeError("native code: cannot keep the library in " + dir.string());
    }
    trim_cache(dir, key, o.cache_limit_bytes, o.timeout);
    return library;
}

}  // namespace

namespace {

// A statement of the generated code, and how many operations it holds (for the pieces).
struct Statement {
    std::string text;
    std::size_t size;
};

// An output evaluated from its row: four sums started at +0 as the interpreter's (a first term of -0 leaves +0).
template <class Name>
Statement row_statement(const CompiledMap::Tape& tape, std::size_t out, Name name) {
    std::ostringstream o;
    const std::vector<Term> terms = row_terms(tape, out);
    o << "  { double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;\n";
    for (const Term& t : terms) o << "    s" << t.sum << " += " << literal(t.coeff) << " * " << name(t.monomial) << ";\n";
    o << "    out[" << out << "] = (s0 + s1) + (s2 + s3); }\n";
    return {o.str(), terms.size() + 1};
}

// A group of four outputs as eval_with's GroupSums: two pairs of lanes (lo: outputs 0, 1; hi: 2, 3) and four partial
// sums of each, term p of the group's L into sum p mod 4 (the last L mod 4 into sum 0), each term the product of
// its coefficient pair and the monomial, masked to +0 in a lane whose coefficient is zero (as GroupSums::add: a
// padding zero adds nothing, even times an infinite monomial) unless the lane has no output; a pair of zeros adds
// +0 and is left out. wide: the four lanes as one AVX2 vector, the same operations lane by lane (a masked +0 added
// to a sum begun at +0 leaves it as it is: such a sum is never -0).
template <class Name>
Statement group_statement(const CompiledMap::Tape& tape, std::size_t g, Name name, bool wide) {
    std::ostringstream o;
    const std::uint32_t start = tape.group_start[g], L = tape.group_start[g + 1] - start, rounds = L / 4 * 4;
    const auto has_output = [&](std::size_t lane) { return tape.group_output[g][lane] != CompiledMap::no_output; };
    std::size_t size = 2;
    o << (wide ? "  { pgi_v4 s0 = {0.0, 0.0, 0.0, 0.0}, s1 = s0, s2 = s0, s3 = s0;\n"
               : "  { pgi_v2 l0 = {0.0, 0.0}, l1 = l0, l2 = l0, l3 = l0, h0 = l0, h1 = l0, h2 = l0, h3 = l0;\n");
    for (std::uint32_t p = 0; p < L; ++p) {
        const std::uint32_t t = start + p;
        const int sum = p < rounds ? int(p % 4) : 0;
        const double* c = &tape.group_coeff[4 * std::size_t(t)];
        const std::size_t width = wide ? 4 : 2;
        for (std::size_t first = 0; first < 4; first += width) {
            std::string coeffs, mask;
            bool any = false, masked = false;
            for (std::size_t lane = first; lane < first + width; ++lane) {
                const bool zero = c[lane] == 0, keep = !zero || !has_output(lane);  // a lane without an output is never read
                any = any || !zero;
                masked = masked || !keep;
                coeffs += (lane > first ? ", " : "") + literal(c[lane]);
                mask += std::string(lane > first ? ", " : "") + (keep ? "-1" : "0");
            }
            if (!any) continue;
            const std::string product = (wide ? "pgi_v4{" : "pgi_v2{") + coeffs + "} * " + name(tape.group_monomial[t]);
            o << "    " << (wide ? "s" : first ? "h" : "l") << sum << " += ";
            if (!masked)
                o << product << ";\n";
            else if (wide)
                o << "(pgi_v4)((pgi_m4)(" << product << ") & pgi_m4{" << mask << "});\n";
            else
                o << "(pgi_v2)((pgi_m2)(" << product << ") & pgi_m2{" << mask << "});\n";
            ++size;
        }
    }
    o << (wide ? "    const pgi_v4 s = (s0 + s1) + (s2 + s3);\n" : "    const pgi_v2 l = (l0 + l1) + (l2 + l3), h = (h0 + h1) + (h2 + h3);\n");
    for (std::size_t i = 0; i < 4; ++i)
        if (has_output(i))
            o << "    out[" << tape.group_output[g][i] << "] = " << (wide ? "s[" + std::to_string(i) : std::string(i < 2 ? "l[" : "h[") + std::to_string(i % 2))
              << "];\n";
    o << "  }\n";
    return {o.str(), size};
}

// Every statement of the map after its inputs: the products, the rows, the groups (eval_with's order).
template <class Name>
std::vector<Statement> statements(const CompiledMap::Tape& tape, Name name, bool wide) {
    std::vector<Statement> all;
    for (std::size_t k = 0; k < tape.products; ++k)
        all.push_back({"  " + name(std::uint32_t(1 + tape.inputs + k), true) + " = " + name(tape.left[k], false) + " * " + name(tape.right[k], false) + ";\n", 1});
    for (std::size_t out = 0; out < tape.outputs; ++out)
        if (tape.lane_row[out].start == UINT32_MAX) all.push_back(row_statement(tape, out, [&](std::uint32_t k) { return name(k, false); }));
    for (std::size_t g = 0; g < tape.groups; ++g) all.push_back(group_statement(tape, g, [&](std::uint32_t k) { return name(k, false); }, wide));
    return all;
}

// A small map: one function, the monomials named values (kept in registers where the compiler can).
void write_single(std::ostream& o, const CompiledMap::Tape& tape, const std::string& symbol, bool wide) {
    const auto name = [](std::uint32_t k, bool defined) {
        std::string n = defined ? "const double m" : "m";
        n += std::to_string(k);
        return n;
    };
    o << "extern \"C\" " << target_attribute(wide) << "void " << symbol << "(const double* __restrict in, double* __restrict out) {\n  const double m0 = 1.0;\n";
    for (std::size_t v = 0; v < tape.inputs; ++v) o << "  const double m" << v + 1 << " = in[" << v << "];\n";
    for (const Statement& s : statements(tape, name, wide)) o << s.text;
    o << "}\n";
}

// A large map: pieces of about piece_size operations, each its own function over the monomials in memory. One
// function of thousands of live values costs the compiler's register allocator time quadratic in them (the radial
// Nambu scene's maps: 47 s for one 33 000-line source); pieces keep it linear.
void write_pieces(std::ostream& o, const CompiledMap::Tape& tape, const std::string& symbol, bool wide) {
    constexpr std::size_t piece_size = 256;
    const auto name = [](std::uint32_t k, bool) { return "m[" + std::to_string(k) + "]"; };
    std::ostringstream call;
    std::size_t pieces = 0, size = 0;
    const auto open_piece = [&] {
        o << "static __attribute__((noinline)) " << target_attribute(wide) << "void " << symbol << "_" << pieces << "(double* __restrict m, double* __restrict out) {\n";
        call << "  " << symbol << "_" << pieces++ << "(m, out);\n";
        size = 0;
    };
    open_piece();
    for (const Statement& s : statements(tape, name, wide)) {
        if (size + s.size > piece_size && size > 0) o << "}\n", open_piece();
        o << s.text;
        size += s.size;
    }
    o << "}\nextern \"C\" " << target_attribute(wide) << "void " << symbol << "(const double* __restrict in, double* __restrict out) {\n";
    o << "  double m[" << 1 + tape.inputs + tape.products << "];\n  m[0] = 1.0;\n";
    for (std::size_t v = 0; v < tape.inputs; ++v) o << "  m[" << v + 1 << "] = in[" << v << "];\n";
    o << call.str() << "}\n";
}

// Maps up to this many terms and monomials are written as one function.
constexpr std::size_t single_function_size = 2000;

// What every source starts with: a group's lanes as GCC's vector extension, pairs (SSE2 on x86-64, as GroupSums)
// or, wide, fours (AVX2).
std::string preamble() {
    return "// pgi: compiled maps as straight-line code (series/native.hpp)\n"
           "typedef double pgi_v2 __attribute__((vector_size(16)));\n"
           "typedef long long pgi_m2 __attribute__((vector_size(16)));\n"
           "typedef double pgi_v4 __attribute__((vector_size(32)));\n"
           "typedef long long pgi_m4 __attribute__((vector_size(32)));\n";
}

std::string map_source(const CompiledMap& map, const std::string& symbol, NativeVectors vectors) {
    const bool fours = wide(vectors, map);
    std::ostringstream o;
    if (map.num_terms() + map.num_monomials() <= single_function_size)
        write_single(o, map.tape(), symbol, fours);
    else
        write_pieces(o, map.tape(), symbol, fours);
    return o.str();
}

}  // namespace

std::string native_source(const CompiledMap& map, const std::string& symbol, NativeVectors vectors) {
    return preamble() + map_source(map, symbol, vectors);
}

std::size_t attach_native_code(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    std::vector<CompiledMap*> todo;
    std::size_t native = 0, budget = options.max_size;
    for (CompiledMap* m : maps) {
        const std::size_t size = m->num_terms() + m->num_monomials();
        if (m->native()) {
            ++native;
        } else if (m->num_outputs() > 0 && size <= options.max_map_size && size <= budget) {
            todo.push_back(m);
            budget -= size;
        }
    }
    if (todo.empty()) return native;
    std::string source = preamble();
    for (std::size_t i = 0; i < todo.size(); ++i) source += map_source(*todo[i], "pgi_map_" + std::to_string(i), options.vectors);
    const fs::path library = library_for(source, options);
    void* handle = ::dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) throw NativeCodeError("native code: cannot load " + library.string() + ": " + ::dlerror());
    const std::shared_ptr<const void> loaded(handle, [](const void* h) { ::dlclose(const_cast<void*>(h)); });
    std::vector<CompiledMap::NativeEval> found;
    for (std::size_t i = 0; i < todo.size(); ++i) {
        void* f = ::dlsym(handle, ("pgi_map_" + std::to_string(i)).c_str());
        if (!f) throw NativeCodeError("native code: " + library.string() + " lacks pgi_map_" + std::to_string(i));
        found.push_back(reinterpret_cast<CompiledMap::NativeEval>(f));
    }
    for (std::size_t i = 0; i < todo.size(); ++i) todo[i]->attach_native(loaded, found[i]);
    return native + todo.size();
}

}  // namespace pgi
