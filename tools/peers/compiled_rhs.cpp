#include "tools/peers/compiled_rhs.hpp"

#include "series/detail/child_process.hpp"
#include "series/message.hpp"
#include "series/native.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace pgi::peers {

namespace {

// A double as a C literal: the shortest digits that read back as the same double, with a point or an exponent.
std::string c_literal(double v) {
    if (!std::isfinite(v)) throw std::invalid_argument("a coefficient does not fit in a double");
    char buffer[64];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, v);
    std::string s(buffer, end);
    if (s.find_first_of(".e") == std::string::npos) s += ".0";
    return s;
}

// The polynomial f over the variables at[ring variable] (its position among the inputs, -1 for none) as a C
// expression in the locals names: its terms in FLINT's order, each coefficient times its variables' products.
std::string c_expression(const Poly& f, const std::vector<long>& at, const std::vector<std::string>& locals) {
    if (f.is_zero()) return "0.0";
    std::string out;
    for (std::size_t i = 0; i < f.length(); ++i) {
        const double c = f.term_coeff(i).to_double();
        const std::vector<unsigned long> e = f.term_exponents(i);
        std::string monomial;
        for (std::size_t v = 0; v < e.size(); ++v) {
            if (e[v] == 0) continue;
            if (v >= at.size() || at[v] < 0)
                throw std::invalid_argument("rhs_c_source: a term holds a variable that is not an input");
            for (unsigned long k = 0; k < e[v]; ++k)
                monomial += (monomial.empty() ? "" : "*") + locals[std::size_t(at[v])];
        }
        const double a = std::abs(c);
        std::string term = monomial.empty() ? c_literal(a) : a == 1 ? monomial : c_literal(a) + "*" + monomial;
        out += i == 0 ? (c < 0 ? "-" : "") + term : (c < 0 ? " - " : " + ") + term;
    }
    return out;
}

// Text for a C comment: printable, no end of comment.
std::string comment_text(const std::string& s) {
    std::string t = printable(s);
    for (std::size_t p; (p = t.find("*/")) != std::string::npos;) t.replace(p, 2, "* /");
    return t;
}

std::vector<std::string> default_compiler() {
    std::vector<std::string> words;
    if (const char* cc = std::getenv("CC"); cc && *cc) {
        std::istringstream in(cc);
        for (std::string w; in >> w;) words.push_back(w);
    }
    if (words.empty()) words.push_back("cc");
    return words;
}

// A directory of our own (mkdtemp: 0700, a fresh name), removed with what is left in it when it goes.
class PrivateDirectory {
public:
    PrivateDirectory() {
        const char* tmp = std::getenv("TMPDIR");
        std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/pgi-peers-XXXXXX";
        if (!::mkdtemp(pattern.data()))  // (TMPDIR a file, missing or read-only: the compiler's failure, exit 7)
            throw NativeCodeError("the peers' right-hand side: cannot make a directory like " + printable(pattern) +
                                  ": " + std::generic_category().message(errno) +
                                  " (set TMPDIR to a writable directory)");
        path_ = pattern;
    }
    PrivateDirectory(const PrivateDirectory&) = delete;
    PrivateDirectory& operator=(const PrivateDirectory&) = delete;
    ~PrivateDirectory() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    std::string file(const std::string& name) const { return path_ + "/" + name; }

private:
    std::string path_;
};

}  // namespace

std::string rhs_c_source(const std::vector<Poly>& field, const std::vector<std::size_t>& vars,
                         const std::vector<std::string>& names, const std::string& title, bool jacobian) {
    const std::size_t n = vars.size();
    if (field.size() != n || names.size() != n)
        throw std::invalid_argument("rhs_c_source: one output and one name per variable");
    std::vector<long> at;
    std::vector<std::string> locals;
    for (std::size_t i = 0; i < n; ++i) {
        if (at.size() <= vars[i]) at.resize(vars[i] + 1, -1);
        at[vars[i]] = long(i);
        locals.push_back("v_" + names[i]);  // names are identifiers: v_NAME is one, and no C keyword
    }
    std::ostringstream o;
    o << "/* " << comment_text(title) << ": pi grad H and its Jacobian, for GSL's odeiv2 (and Boost.Odeint),\n"
      << "   written by pgi_peers from the scene's exact polynomials (tools/peers/compiled_rhs.hpp). */\n"
      << "#include <string.h>\n\n";
    const auto read_locals = [&] {
        for (std::size_t i = 0; i < n; ++i) o << "  const double " << locals[i] << " = y[" << i << "];\n";
    };
    o << "int pgi_peer_rhs(double t, const double y[], double f[], void *params) {\n"
      << "  (void)t; (void)params;\n";
    read_locals();
    for (std::size_t i = 0; i < n; ++i) o << "  f[" << i << "] = " << c_expression(field[i], at, locals) << ";\n";
    o << "  return 0; /* GSL_SUCCESS */\n}\n";
    if (!jacobian) return o.str();
    o << "\nint pgi_peer_jacobian(double t, const double y[], double *dfdy, double dfdt[], void *params) {\n"
      << "  (void)t; (void)params;\n";
    read_locals();
    // small systems: every entry written, as by hand; larger ones: zeros first, then the entries that are not zero
    const bool every_entry = n <= 8;
    if (!every_entry) o << "  memset(dfdy, 0, sizeof(double) * " << n * n << ");\n";
    for (std::size_t i = 0; i < n; ++i) {
        std::map<std::size_t, std::string> row;  // column -> entry
        for (std::size_t v : used_variables(field[i])) {
            if (v >= at.size() || at[v] < 0)
                throw std::invalid_argument("rhs_c_source: a term holds a variable that is not an input");
            const Poly d = derivative(field[i], v);
            if (!d.is_zero()) row[std::size_t(at[v])] = c_expression(d, at, locals);
        }
        if (every_entry)
            for (std::size_t j = 0; j < n; ++j) row.emplace(j, "0.0");  // (keeps the entries found)
        for (const auto& [j, entry] : row) o << "  dfdy[" << i * n + j << "] = " << entry << ";\n";
    }
    o << "  for (int i = 0; i < " << n << "; ++i) dfdt[i] = 0.0;\n";
    o << "  return 0;\n}\n";
    return o.str();
}

CompiledRhs compile_rhs(const std::string& source, std::size_t n, const RhsCompileOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::string> argv = options.compiler.empty() ? default_compiler() : options.compiler;
    argv.insert(argv.end(), options.flags.begin(), options.flags.end());
    argv.insert(argv.end(), {"-fPIC", "-shared"});
    CompiledRhs out;
    for (const auto& w : argv) out.command += (out.command.empty() ? "" : " ") + w;
    const std::string what = "the peers' right-hand side: the compiler `" + printable(out.command) + "` ";
    const PrivateDirectory dir;
    TemporaryFile src(dir.file("rhs.c")), lib(dir.file("rhs.so"));
    {
        std::ofstream f(src.path(), std::ios::binary);
        f << source;
        f.close();
        if (!f) throw NativeCodeError("the peers' right-hand side: cannot write " + src.path());
    }
    argv.insert(argv.end(), {"-o", lib.path(), src.path()});
    const ChildResult run = run_child(argv, {.timeout = std::chrono::minutes(2)});
    if (!run.ok()) {
        const std::string tail = output_tail(run.output);
        throw NativeCodeError(what + run.failure + (tail.empty() ? "" : ": " + tail) + " (set CC to a C compiler)");
    }
    void* handle = ::dlopen(lib.path().c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char* e = ::dlerror();
        throw NativeCodeError(what + "wrote a library that cannot be loaded (" + printable(e ? e : "dlopen") + ")");
    }
    out.library = std::shared_ptr<void>(handle, [](void* h) { ::dlclose(h); });
    out.rhs = reinterpret_cast<RhsFunction>(::dlsym(handle, "pgi_peer_rhs"));
    if (!out.rhs) throw NativeCodeError(what + "wrote a library without pgi_peer_rhs");
    if (source.find("int pgi_peer_jacobian(") != std::string::npos) {
        out.jacobian = reinterpret_cast<JacobianFunction>(::dlsym(handle, "pgi_peer_jacobian"));
        if (!out.jacobian) throw NativeCodeError(what + "wrote a library without pgi_peer_jacobian");
    }
    out.n = n;
    out.source = source;
    out.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;  // the files and the directory go now; the library stays mapped
}

CompiledRhs compile_rhs(const std::vector<Poly>& field, const std::vector<std::size_t>& vars,
                        const std::vector<std::string>& names, const std::string& title,
                        const RhsCompileOptions& options, bool jacobian) {
    return compile_rhs(rhs_c_source(field, vars, names, title, jacobian), vars.size(), options);
}

}  // namespace pgi::peers
