#include "series/native.hpp"

#include "series/detail/child_process.hpp"
#include "series/message.hpp"
#include "series/detail/sha256.hpp"

#include <dirent.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <wordexp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <utility>

namespace pgi {

namespace fs = std::filesystem;

namespace {

// The terms of an output the interpreter evaluates from its row (eval_with), each with the partial sum (0..3) it
// adds it to, in its order: the first L - L mod 4 terms round-robin, the rest into sum 0; coeff is the term's index
// in the map's term_coeff.
struct Term {
    int sum;
    std::uint32_t monomial, coeff;
};
std::vector<Term> row_terms(const CompiledMap::Tape& tape, std::size_t o) {
    std::vector<Term> terms;
    const std::uint32_t start = tape.row_start[o], L = tape.row_start[o + 1] - start, rounds = L / 4 * 4;
    for (std::uint32_t i = 0; i < L; ++i)
        terms.push_back({i < rounds ? int(i % 4) : 0, tape.term_monomial[start + i], start + i});
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
        const char* why = r == WRDE_CMDSUB    ? "command substitution is not allowed"
                          : r == WRDE_BADCHAR ? "an unquoted | & ; < > ( ) { } or newline"
                          : r == WRDE_SYNTAX  ? "a syntax error (an unbalanced quote?)"
                          : r == 0            ? "no words"
                                              : "it cannot be split";
        throw NativeCodeError("native code: the compiler command `" + printable(command) + "` cannot be used: " + why);
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
// itself is built for the baseline. The code calls no function of any library (not even the stack protector's, which
// some compilers enable by default), so none is linked: 0.04 s of the 0.10-0.17 s a map's library takes here.
std::vector<std::string> compiler_flags() {
    return {"-O2", "-ffp-contract=off", "-fPIC", "-shared", "-nostdlib", "-fno-stack-protector", "-w"};
}

std::string target_attribute(bool wide) {
    return wide ? "__attribute__((target(\"avx2\"))) " : "";
}

// A file descriptor closed when it goes out of scope.
class Fd {
public:
    explicit Fd(int fd = -1) : fd_(fd) {}
    Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
    Fd& operator=(Fd&& o) noexcept {
        std::swap(fd_, o.fd_);
        return *this;
    }
    ~Fd() {
        if (fd_ >= 0) ::close(fd_);
    }
    int get() const { return fd_; }

private:
    int fd_;
};

std::string octal_mode(mode_t mode) {
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "%04o", unsigned(mode & 07777));
    return buffer;
}

// Creates the missing directories of path, each 0700 whatever the umask.
void create_private_directories(const fs::path& path) {
    fs::path prefix;
    for (const fs::path& part : path) {
        prefix /= part;
        if (::mkdir(prefix.c_str(), 0700) == 0) ::chmod(prefix.c_str(), 0700);
    }
}

// The cache directory, opened once and checked: owned by the effective user, not writable by group or others, not a
// symbolic link. Every file operation goes through its descriptor (openat, renameat, ...), so what is read and loaded
// is what this directory holds even if its path is changed meanwhile.
class CacheDir {
public:
    // The directory at path, created (0700) if missing; nullopt with why_not set when it cannot be used.
    static std::optional<CacheDir> open(const fs::path& path, std::string& why_not) {
        create_private_directories(path);
        struct stat link {};
        if (::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode)) {
            why_not = "it is a symbolic link";
            return std::nullopt;
        }
        Fd fd(::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
        struct stat st {};
        if (fd.get() < 0 || ::fstat(fd.get(), &st) != 0) {
            why_not = errno == ELOOP
                          ? "it is a symbolic link"
                          : std::string("cannot be opened (") + std::strerror(errno) + ")";  // (made one meanwhile)
            return std::nullopt;
        }
        if (st.st_uid != ::geteuid())
            why_not = "it is owned by uid " + std::to_string(st.st_uid) + ", not by the effective user (uid " +
                      std::to_string(::geteuid()) + ")";
        else if (st.st_mode & (S_IWGRP | S_IWOTH))
            why_not = "it is writable by " + std::string(st.st_mode & S_IWOTH ? "others" : "its group") + " (mode " +
                      octal_mode(st.st_mode) + "; chmod go-w it)";
        else if ((st.st_mode & S_IRWXU) != S_IRWXU || ::faccessat(fd.get(), ".", W_OK | X_OK, AT_EACCESS) != 0)
            why_not = "it is not writable (mode " + octal_mode(st.st_mode) + ")";
        if (!why_not.empty()) return std::nullopt;
        return CacheDir(path, std::move(fd));
    }

    const fs::path& path() const { return path_; }

    // The regular file name owned by the effective user, opened for reading without following a link; -1 if none.
    Fd open_file(const std::string& name) const {
        Fd fd(::openat(fd_.get(), name.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK));
        struct stat st {};
        if (fd.get() < 0 || ::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_uid != ::geteuid())
            return Fd();
        return fd;
    }

    // The contents of name (see open_file), nullopt if absent or above max bytes.
    std::optional<std::string> read(const std::string& name, std::size_t max) const {
        return read_fd(open_file(name), max);
    }

    // Writes a new file name (never an existing one, never through a link) with exactly the given mode.
    void write_new(const std::string& name, const std::string& text, mode_t mode) const {
        const Fd fd(::openat(fd_.get(), name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600));
        bool ok = fd.get() >= 0 && ::fchmod(fd.get(), mode) == 0;
        for (std::size_t done = 0; ok && done < text.size();) {
            const ssize_t n = ::write(fd.get(), text.data() + done, text.size() - done);
            if (n < 0 && errno == EINTR) continue;
            ok = n > 0;
            done += ok ? std::size_t(n) : 0;
        }
        if (!ok)
            throw NativeCodeError("native code: cannot write " + (path_ / name).string() + " (" + std::strerror(errno) +
                                  ")");
    }

    bool rename(const std::string& from, const std::string& to) const {
        return ::renameat(fd_.get(), from.c_str(), fd_.get(), to.c_str()) == 0;
    }

    static std::optional<std::string> read_fd(const Fd& fd, std::size_t max) {
        struct stat st {};
        if (fd.get() < 0 || ::fstat(fd.get(), &st) != 0 || std::size_t(st.st_size) > max) return std::nullopt;
        std::string text(std::size_t(st.st_size), '\0');
        std::size_t got = 0;
        while (got < text.size()) {
            const ssize_t n = ::pread(fd.get(), text.data() + got, text.size() - got, off_t(got));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) return std::nullopt;
            got += std::size_t(n);
        }
        return text;
    }

    int fd() const { return fd_.get(); }

private:
    CacheDir(fs::path path, Fd fd) : path_(std::move(path)), fd_(std::move(fd)) {}
    fs::path path_;
    Fd fd_;
};

// The directory kept libraries go to (NativeOptions::cache_dir), created if missing and checked (CacheDir). One the
// caller names (cache_dir or $PGI_JIT_CACHE) is the only candidate: unusable, it is an error naming it, not a silent
// fallback; of the default ones the first usable is taken.
CacheDir cache_directory(const NativeOptions& o) {
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
        if (!ec) candidates.push_back(tmp / ("pgi-jit-" + std::to_string(::geteuid())));
    }
    std::string tried;
    for (const fs::path& d : candidates) {
        std::string why_not;
        if (std::optional<CacheDir> dir = CacheDir::open(d, why_not)) return std::move(*dir);
        tried += (tried.empty() ? "" : "; ") + d.string() + ": " + why_not;
    }
    throw NativeCodeError("native code: no usable directory for the compiled libraries (" +
                          (tried.empty() ? "none found" : tried) + ")");
}

// FNV-1a: the cache key of a source and its command, a name only (the kept source is compared in full, the library
// against its SHA-256 digest, before either is used).
std::string key_of(const std::string& text) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
    char buffer[20];
    std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(h));
    return buffer;
}

// The names pgi gives in its cache, and only those: KEY.cpp, KEY.so, KEY.hash (kept) and KEY.PID-RANDOM.EXT
// (a build's temporaries), KEY 16 lowercase hex digits. Trimming never touches another name.
enum class CacheName { other, kept, temporary };
CacheName cache_name(std::string_view name) {
    const auto hex = [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); };
    const auto digits = [](std::string_view s) {
        return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    if (name.size() < 18 || !std::all_of(name.begin(), name.begin() + 16, hex) || name[16] != '.')
        return CacheName::other;
    std::string_view rest = name.substr(17);
    const std::size_t dot = rest.rfind('.');
    const std::string_view ext = dot == std::string_view::npos ? rest : rest.substr(dot + 1);
    if (dot == std::string_view::npos)
        return ext == "cpp" || ext == "so" || ext == "hash" ? CacheName::kept : CacheName::other;
    const std::string_view suffix = rest.substr(0, dot);
    const std::size_t dash = suffix.find('-');
    const bool pgi_suffix =
        dash != std::string_view::npos && digits(suffix.substr(0, dash)) && digits(suffix.substr(dash + 1));
    return pgi_suffix && (ext == "cpp" || ext == "so" || ext == "hash" || ext == "log") ? CacheName::temporary
                                                                                        : CacheName::other;
}

// A name no other process picks: for files written and then renamed into place.
std::string unique_suffix() {
    std::random_device rd;
    return std::to_string(::getpid()) + "-" + std::to_string(rd());
}

// Removes the temporaries of killed builds (a running build's, younger, are neither removed nor counted), then the
// oldest kept files (by last write, the key's spared) while they hold more than limit bytes. Only pgi's own names
// (cache_name) that are regular files are looked at. Best effort: a file another process removes first is passed over.
void trim_cache(const CacheDir& dir, const std::string& key, std::uintmax_t limit, std::chrono::seconds timeout) {
    DIR* listing = ::fdopendir(::dup(dir.fd()));
    if (!listing) return;
    const std::unique_ptr<DIR, int (*)(DIR*)> closer(listing, ::closedir);
    // a temporary older than a compiler is given is a build that was killed: it goes
    const std::time_t stale = std::time(nullptr) - std::time_t(timeout.count()) - 60;
    std::vector<std::pair<std::time_t, std::string>> kept;
    std::map<std::string, std::uintmax_t> sizes;
    std::uintmax_t total = 0;
    while (const dirent* e = ::readdir(listing)) {
        const std::string name = e->d_name;
        const CacheName kind = cache_name(name);
        struct stat st {};
        if (kind == CacheName::other || ::fstatat(dir.fd(), name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0 ||
            !S_ISREG(st.st_mode))
            continue;
        if (kind == CacheName::temporary) {
            if (st.st_mtime < stale) ::unlinkat(dir.fd(), name.c_str(), 0);
            continue;
        }
        total += std::uintmax_t(st.st_size);
        if (name.compare(0, key.size(), key) != 0)
            kept.push_back({st.st_mtime, name}), sizes[name] = std::uintmax_t(st.st_size);
    }
    std::sort(kept.begin(), kept.end());
    for (const auto& [time, name] : kept) {
        if (total <= limit) break;
        if (::unlinkat(dir.fd(), name.c_str(), 0) == 0) total -= sizes[name];
    }
}

// dlclose as a shared_ptr's deleter.
std::shared_ptr<void> own_handle(void* handle) {
    return std::shared_ptr<void>(handle, [](void* h) { ::dlclose(h); });
}

// The library name in dir, loaded (RTLD_NOW | RTLD_LOCAL) through the directory's descriptor (/proc/self/fd/N/NAME, so
// a directory swapped after it was checked is never where it is loaded from), with every symbol in place; "" and the
// handle, or why not. NOTE: glibc returns an object already loaded under the same name; the names are keyed by the
// source, so such an object holds the same code.
std::string load_checked(const CacheDir& dir, const std::string& name, const std::vector<std::string>& symbols,
                         std::shared_ptr<void>& handle) {
    const std::string via_fd = "/proc/self/fd/" + std::to_string(dir.fd());
    const std::string path = (::access(via_fd.c_str(), X_OK) == 0 ? fs::path(via_fd) : dir.path()) / name;
    void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char* error = ::dlerror();
        return "is not a loadable library (" + printable(error ? error : "dlopen failed") + ")";
    }
    handle = own_handle(h);
    for (const std::string& s : symbols)
        if (!::dlsym(h, s.c_str())) {
            handle.reset();
            return "is a library without the function " + s;
        }
    return "";
}

// The largest library read to check its digest.
constexpr std::size_t max_library_bytes = std::size_t(1) << 30;

// What KEY.hash holds: the digests of the command and source the library was built from, and of the library. The
// first ties a library to its build: a library and its digest copied from another key (a restored or merged cache)
// match each other, not the source asked for, and are never loaded.
std::string kept_digest(const std::string& build, const std::string& library) {
    return detail::sha256_hex(build) + " " + detail::sha256_hex(library) + "\n";
}

// The kept library of key, loaded, when its source is source, its digests the ones pgi wrote beside it for this build
// (the command and source, build) and it holds every symbol; else null (and it is built anew, replacing whatever was
// there).
std::shared_ptr<void> load_kept(const CacheDir& dir, const std::string& key, const std::string& build,
                                const std::string& source, const std::vector<std::string>& symbols) {
    const std::optional<std::string> kept_source = dir.read(key + ".cpp", source.size());
    const std::optional<std::string> digest = dir.read(key + ".hash", 256);
    if (!kept_source || *kept_source != source || !digest) return nullptr;
    const Fd fd = dir.open_file(key + ".so");
    const std::optional<std::string> bytes = CacheDir::read_fd(fd, max_library_bytes);
    if (!bytes || *digest != kept_digest(build, *bytes)) return nullptr;
    std::shared_ptr<void> handle;
    load_checked(dir, key + ".so", symbols, handle);
    return handle;
}

// The library of source with the given symbols, loaded: the kept one if its source, digest and symbols check
// (load_kept), else compiled now into temporaries, loaded and checked, then renamed into place with its digest beside
// it (a concurrent build of the same source keeps one of the two; a pair that does not match is built again).
// Only the kept library (null if there is none) when compile is false; cancel, when set, is the compiler's (run_child).
std::shared_ptr<void> library_for(const std::string& source, const std::vector<std::string>& symbols,
                                  const NativeOptions& o, bool compile = true,
                                  const std::atomic<bool>* cancel = nullptr) {
    std::vector<std::string> argv = compiler_words(compiler_of(o));
    const std::vector<std::string> flags = compiler_flags();
    argv.insert(argv.end(), flags.begin(), flags.end());
    std::string command;
    for (const std::string& word : argv) command += (command.empty() ? "" : " ") + word;
    const CacheDir dir = cache_directory(o);
    const std::string build = command + "\n" + source, key = key_of(build);
    if (std::shared_ptr<void> kept = load_kept(dir, key, build, source, symbols)) return kept;
    if (!compile) return nullptr;
    const std::string tmp = key + "." + unique_suffix();
    TemporaryFile src((dir.path() / (tmp + ".cpp")).string()), lib((dir.path() / (tmp + ".so")).string()),
        hash((dir.path() / (tmp + ".hash")).string());
    dir.write_new(tmp + ".cpp", source, 0600);
    argv.insert(argv.end(), {"-o", lib.path(), src.path()});
    const std::string compiler = "native code: the compiler `" + printable(command) + "` ";
    const ChildResult run =
        run_child(argv, {.timeout = o.timeout, .output_limit = std::size_t(64) << 10, .cancel = cancel});
    if (!run.ok()) {
        const std::string output = output_tail(run.output);
        throw NativeCodeError(compiler + run.failure + (output.empty() ? "" : ": " + output));
    }
    const Fd fd = dir.open_file(tmp + ".so");
    if (fd.get() < 0) throw NativeCodeError(compiler + "exited with status 0 but wrote no library");
    ::fchmod(fd.get(), 0700);
    const std::optional<std::string> bytes = CacheDir::read_fd(fd, max_library_bytes);
    std::shared_ptr<void> handle;
    const std::string why = bytes ? load_checked(dir, tmp + ".so", symbols, handle) : "cannot be read";
    if (!why.empty())
        throw NativeCodeError(compiler + "exited with status 0 but what it wrote " + why + " (nothing kept)");
    dir.write_new(tmp + ".hash", kept_digest(build, *bytes), 0600);
    // the library first, its digest last: a reader between the renames finds a mismatch and builds again
    if (!dir.rename(tmp + ".so", key + ".so") || !dir.rename(tmp + ".cpp", key + ".cpp") ||
        !dir.rename(tmp + ".hash", key + ".hash"))
        throw NativeCodeError("native code: cannot keep the library in " + dir.path().string() + " (" +
                              std::strerror(errno) + ")");
    src.keep(), lib.keep(), hash.keep();
    trim_cache(dir, key, o.cache_limit_bytes, o.timeout);
    return handle;
}

}  // namespace

namespace {

// A statement of the generated code, and how many operations it holds (for the pieces).
struct Statement {
    std::string text;
    std::size_t size;
};

// Which coefficient a term's is, for the structure the code holds: its bits or, with slow inputs, its slot (the
// coefficients are bound from the slow inputs' values at run time: those of one slot are equal at every value).
std::uint64_t row_identity(const CompiledMap::Tape& tape, std::uint32_t t) {
    return tape.slow ? tape.term_slot[t] : std::bit_cast<std::uint64_t>(tape.term_coeff[t]);
}
std::uint64_t group_identity(const CompiledMap::Tape& tape, std::size_t i) {
    return tape.slow ? tape.group_slot[i] : std::bit_cast<std::uint64_t>(tape.group_coeff[i]);
}
// Whether group coefficient i is zero whatever the map's dt or slow inputs (then its lane is masked).
bool group_zero(const CompiledMap::Tape& tape, std::size_t i) {
    return tape.slow ? tape.group_slot[i] == CompiledMap::no_output : tape.group_coeff[i] == 0;
}

// Where the code reads each coefficient: the first place in the map's arrays that holds the same one (row_identity;
// read once, as the compiler keeps one constant once). Which coefficients are equal is part of the structure the code
// holds, and of its source: two terms whose S_j's coefficients are equal are equal at every dt; a coincidence at one
// dt only makes another source, a library of its own (the source is the key and is compared).
class CoefficientReads {
public:
    explicit CoefficientReads(const CompiledMap::Tape& tape) : tape_(tape) {}
    std::string row(std::uint32_t t) {
        const auto [it, added] = rows_.try_emplace(row_identity(tape_, t), t);
        return "rc[" + std::to_string(it->second) + "]";
    }
    // lanes first .. first + width - 1 of group term t, as a vector
    std::string group(std::uint32_t t, std::size_t first, std::size_t width) {
        std::array<std::uint64_t, 5> key{width};
        for (std::size_t i = 0; i < width; ++i) key[1 + i] = group_identity(tape_, 4 * std::size_t(t) + first + i);
        const auto [it, added] = groups_.try_emplace(key, 4 * std::size_t(t) + first);
        std::string read = width == 4 ? "pgi_load4(gc + " : "pgi_load2(gc + ";
        read += std::to_string(it->second);
        read += ')';
        return read;
    }

private:
    const CompiledMap::Tape& tape_;
    std::map<std::uint64_t, std::uint32_t> rows_;
    std::map<std::array<std::uint64_t, 5>, std::size_t> groups_;
};

// An output evaluated from its row: four sums started at +0 as the interpreter's (a first term of -0 leaves +0).
template <class Name>
Statement row_statement(const CompiledMap::Tape& tape, std::size_t out, Name name, CoefficientReads& reads) {
    std::ostringstream o;
    const std::vector<Term> terms = row_terms(tape, out);
    o << "  { double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;\n";
    for (const Term& t : terms)
        o << "    s" << t.sum << " += " << reads.row(t.coeff) << " * " << name(t.monomial) << ";\n";
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
Statement group_statement(const CompiledMap::Tape& tape, std::size_t g, Name name, bool wide, CoefficientReads& reads) {
    std::ostringstream o;
    const std::uint32_t start = tape.group_start[g], L = tape.group_start[g + 1] - start, rounds = L / 4 * 4;
    const auto has_output = [&](std::size_t lane) { return tape.group_output[g][lane] != CompiledMap::no_output; };
    std::size_t size = 2;
    o << (wide ? "  { pgi_v4 s0 = {0.0, 0.0, 0.0, 0.0}, s1 = s0, s2 = s0, s3 = s0;\n"
               : "  { pgi_v2 l0 = {0.0, 0.0}, l1 = l0, l2 = l0, l3 = l0, h0 = l0, h1 = l0, h2 = l0, h3 = l0;\n");
    for (std::uint32_t p = 0; p < L; ++p) {
        const std::uint32_t t = start + p;
        const int sum = p < rounds ? int(p % 4) : 0;
        const std::size_t width = wide ? 4 : 2;
        for (std::size_t first = 0; first < 4; first += width) {
            std::string mask;
            bool any = false, masked = false;
            for (std::size_t lane = first; lane < first + width; ++lane) {
                const bool zero = group_zero(tape, 4 * std::size_t(t) + lane),
                           keep = !zero || !has_output(lane);  // a lane without an output is never read
                any = any || !zero;
                masked = masked || !keep;
                mask += std::string(lane > first ? ", " : "") + (keep ? "-1" : "0");
            }
            if (!any) continue;
            const std::string product = reads.group(t, first, width) + " * " + name(tape.group_monomial[t]);
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
    o << (wide ? "    const pgi_v4 s = (s0 + s1) + (s2 + s3);\n"
               : "    const pgi_v2 l = (l0 + l1) + (l2 + l3), h = (h0 + h1) + (h2 + h3);\n");
    for (std::size_t i = 0; i < 4; ++i)
        if (has_output(i))
            o << "    out[" << tape.group_output[g][i]
              << "] = " << (wide ? "s[" + std::to_string(i) : std::string(i < 2 ? "l[" : "h[") + std::to_string(i % 2))
              << "];\n";
    o << "  }\n";
    return {o.str(), size};
}

// Every statement of the map after its inputs: the products, the rows, the groups (eval_with's order).
template <class Name>
std::vector<Statement> statements(const CompiledMap::Tape& tape, Name name, bool wide) {
    std::vector<Statement> all;
    for (std::size_t k = 0; k < tape.products; ++k)
        all.push_back({"  " + name(std::uint32_t(1 + tape.inputs + k), true) + " = " + name(tape.left[k], false) +
                           " * " + name(tape.right[k], false) + ";\n",
                       1});
    CoefficientReads reads(tape);
    const auto read = [&](std::uint32_t k) { return name(k, false); };
    for (std::size_t out = 0; out < tape.outputs; ++out)
        if (tape.lane_row[out].start == UINT32_MAX) all.push_back(row_statement(tape, out, read, reads));
    for (std::size_t g = 0; g < tape.groups; ++g) all.push_back(group_statement(tape, g, read, wide, reads));
    return all;
}

// A small map: one function, the monomials named values (kept in registers where the compiler can).
void write_single(std::ostream& o, const CompiledMap::Tape& tape, const std::string& symbol, bool wide) {
    const auto name = [](std::uint32_t k, bool defined) {
        std::string n = defined ? "const double m" : "m";
        n += std::to_string(k);
        return n;
    };
    o << "extern \"C\" " << target_attribute(wide) << "void " << symbol
      << "(const double* __restrict in, const double* __restrict rc, const double* __restrict gc, "
         "double* __restrict out) {\n  const double m0 = 1.0;\n";
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
        o << "static __attribute__((noinline)) " << target_attribute(wide) << "void " << symbol << "_" << pieces
          << "(double* __restrict m, const double* __restrict rc, const double* __restrict gc, "
             "double* __restrict out) {\n";
        call << "  " << symbol << "_" << pieces++ << "(m, rc, gc, out);\n";
        size = 0;
    };
    open_piece();
    for (const Statement& s : statements(tape, name, wide)) {
        if (size + s.size > piece_size && size > 0) o << "}\n", open_piece();
        o << s.text;
        size += s.size;
    }
    o << "}\nextern \"C\" " << target_attribute(wide) << "void " << symbol
      << "(const double* __restrict in, const double* __restrict rc, const double* __restrict gc, "
         "double* __restrict out) {\n";
    o << "  double m[" << 1 + tape.inputs + tape.products << "];\n  m[0] = 1.0;\n";
    for (std::size_t v = 0; v < tape.inputs; ++v) o << "  m[" << v + 1 << "] = in[" << v << "];\n";
    o << call.str() << "}\n";
}

// Maps up to this many terms and monomials are written as one function.
constexpr std::size_t single_function_size = 2000;

// What every source starts with: a group's lanes as GCC's vector extension, pairs (SSE2 on x86-64, as GroupSums)
// or, wide, fours (AVX2), and how a group's coefficients are read: a pair aligned (group_coeff is operator new's,
// 16-byte aligned, and a pair starts at an even index), so that SSE2's multiply reads it from memory itself; four
// unaligned (AVX2's multiply reads any address).
std::string preamble() {
    return "// pgi: compiled maps as straight-line code (series/native.hpp)\n"
           "typedef double pgi_v2 __attribute__((vector_size(16)));\n"
           "typedef long long pgi_m2 __attribute__((vector_size(16)));\n"
           "typedef double pgi_v4 __attribute__((vector_size(32)));\n"
           "typedef long long pgi_m4 __attribute__((vector_size(32)));\n"
           "typedef double pgi_a2 __attribute__((vector_size(16), may_alias));\n"
           "typedef double pgi_u4 __attribute__((vector_size(32), aligned(8), may_alias));\n"
           "#define pgi_load2(p) (*(const pgi_a2*)(p))\n"
           "#define pgi_load4(p) ((pgi_v4)(*(const pgi_u4*)(p)))\n";
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

std::size_t native_count(const std::vector<CompiledMap*>& maps) {
    return std::size_t(std::count_if(maps.begin(), maps.end(), [](const CompiledMap* m) { return m->native(); }));
}

std::vector<std::size_t> native_candidates(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    std::vector<std::size_t> todo;
    std::size_t budget = options.max_size;
    for (std::size_t i = 0; i < maps.size(); ++i) {
        const CompiledMap& m = *maps[i];
        const std::size_t size = m.num_terms() + m.num_monomials();
        if (m.native()) {
            budget -= std::min(budget, size);  // (kept native code counts: max_size bounds the maps' native code)
        } else if (m.num_outputs() > 0 && size <= options.max_map_size && size <= budget) {
            todo.push_back(i);
            budget -= size;
        }
    }
    return todo;
}

namespace detail {  // (named, not anonymous: NativeBuild::State holds one)

// attach_native_code's plan: which maps get native code (the maps in the order given while they fit), each map's
// source (a library of its own: a map's library serves it wherever it comes again, whatever the other maps of a step
// at another dt are), and how many are native already.
struct NativePlan {
    std::vector<std::size_t> todo;
    std::vector<std::string> sources;
    std::size_t native = 0;
    NativeVectors vectors = NativeVectors::automatic;
};

}  // namespace detail

namespace {

using detail::NativePlan;

// The one function of each map's library.
const std::vector<std::string> map_symbols = {"pgi_map"};

NativePlan plan_native(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    NativePlan plan;
    plan.vectors = options.vectors;
    plan.native = native_count(maps);
    plan.todo = native_candidates(maps, options);
    for (const std::size_t i : plan.todo)
        plan.sources.push_back(preamble() + map_source(*maps[i], map_symbols.front(), options.vectors));
    return plan;
}

// The plan's maps in maps (the maps planned, or a copy of them in the same order) given their libraries (null: the
// map stays as it is); how many maps run native code afterwards. checked: maps may be other maps than the planned
// ones, and each is given its library only if its source is the planned one.
std::size_t attach_planned(const std::vector<CompiledMap*>& maps, const NativePlan& plan,
                           const std::vector<std::shared_ptr<void>>& libraries, bool checked = false) {
    for (std::size_t i = 0; i < plan.todo.size(); ++i) {
        if (plan.todo[i] >= maps.size()) break;
        CompiledMap& m = *maps[plan.todo[i]];
        if (m.native() || !libraries.at(i)) continue;
        if (checked && preamble() + map_source(m, map_symbols.front(), plan.vectors) != plan.sources[i]) continue;
        m.attach_native(libraries[i], reinterpret_cast<CompiledMap::NativeEval>(
                                          ::dlsym(libraries[i].get(), map_symbols.front().c_str())));
    }
    return native_count(maps);
}

// Each planned map's library: kept or, when compile is set, built, by up to `compilers` compilers at once (each map's
// its own: they run side by side on a machine's cores); NativeCodeError, the first planned map's that could not be,
// once all have ended. Without compile, null for those not kept.
std::vector<std::shared_ptr<void>> plan_libraries(const NativePlan& plan, const NativeOptions& options, bool compile,
                                                  std::size_t compilers = 1,
                                                  const std::atomic<bool>* cancel = nullptr) {
    const std::size_t n = plan.sources.size();
    std::vector<std::shared_ptr<void>> libraries(n);
    std::vector<std::exception_ptr> errors(n);
    std::atomic<std::size_t> next{0};
    const auto work = [&] {
        for (std::size_t i; (i = next.fetch_add(1)) < n;) try {
                if (cancel && cancel->load(std::memory_order_relaxed))
                    throw NativeCodeError("native code: the build was cancelled");  // (no compiler started)
                libraries[i] = library_for(plan.sources[i], map_symbols, options, compile, cancel);
            } catch (...) {
                errors[i] = std::current_exception();
            }
    };
    std::vector<std::thread> helpers;
    try {
        for (std::size_t t = 1; t < std::min(compilers, n); ++t) helpers.emplace_back(work);
    } catch (const std::system_error&) {
        // no more threads: those started and this one take every map
    }
    work();
    for (std::thread& h : helpers) h.join();
    for (const std::exception_ptr& e : errors)
        if (e) std::rethrow_exception(e);
    return libraries;
}

// The compilers run at once: every core when the caller waits for them (attach_native_code), all but the one the
// caller steps on when they build in the background (NativeBuild); at most 4, so that several builds at once stay
// within the table of children and temporaries a signal cleans up (series/detail/child_process.cpp: 32 and 64).
std::size_t compilers(bool background) {
    const std::size_t cores = std::min(4u, std::max(1u, std::thread::hardware_concurrency()));
    return background ? std::max<std::size_t>(1, cores - 1) : cores;
}

}  // namespace

std::string to_string(NativePolicy p) {
    switch (p) {
        case NativePolicy::automatic:
            return "automatic";
        case NativePolicy::always:
            return "always";
        case NativePolicy::never:
            return "never";
    }
    return "?";
}

std::size_t attach_native_code(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    const NativePlan plan = plan_native(maps, options);
    if (plan.todo.empty()) return plan.native;
    return attach_planned(maps, plan, plan_libraries(plan, options, true, compilers(false)));
}

std::size_t attach_kept_native_code(const std::vector<CompiledMap*>& maps, const NativeOptions& options) {
    const NativePlan plan = plan_native(maps, options);
    if (plan.todo.empty()) return plan.native;
    try {
        return attach_planned(maps, plan, plan_libraries(plan, options, false));
    } catch (const std::exception&) {
        // no usable cache (or no readable library in it): the maps stay interpreted, as without a kept library
    }
    return plan.native;
}

struct NativeBuild::State {
    NativePlan plan;
    NativeOptions options;
    std::atomic<bool> cancel{false}, done{false};
    std::vector<std::shared_ptr<void>> libraries;  // written by the build's thread before done, read after
    std::string failure;
    std::thread thread;
};

NativeBuild::NativeBuild(const std::vector<CompiledMap*>& maps, const NativeOptions& options)
    : state_(std::make_unique<State>()) {
    State& st = *state_;
    st.plan = plan_native(maps, options);
    st.options = options;
    if (st.plan.todo.empty()) {
        st.done.store(true, std::memory_order_release);
        return;
    }
    st.thread = std::thread([&st] {
        try {
            st.libraries = plan_libraries(st.plan, st.options, true, compilers(true), &st.cancel);
        } catch (const std::exception& e) {
            st.failure = e.what();
        }
        st.done.store(true, std::memory_order_release);
    });
}

NativeBuild::~NativeBuild() {
    state_->cancel.store(true, std::memory_order_relaxed);
    if (state_->thread.joinable()) state_->thread.join();
}

bool NativeBuild::done() const {
    return state_->done.load(std::memory_order_acquire);
}

void NativeBuild::wait() const {
    while (!done()) std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

std::size_t NativeBuild::attach(const std::vector<CompiledMap*>& maps) const {
    if (!done() || state_->libraries.empty()) return native_count(maps);
    return attach_planned(maps, state_->plan, state_->libraries, true);
}

std::string NativeBuild::failure() const {
    return done() ? state_->failure : std::string();
}

}  // namespace pgi
