// The budgets of the exact phase and of the parser as a user meets them in the pgi program: exit 4 (budget
// exceeded) or 5 (out of memory) with a message, never an abort, in bounded time; progress on a terminal.
#include <doctest/doctest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool address_sanitizer = true;  // it reserves terabytes of address space: no ulimit -v
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool address_sanitizer = true;
#else
constexpr bool address_sanitizer = false;
#endif
#else
constexpr bool address_sanitizer = false;
#endif

struct Shell {
    int exit_code;  // a signal shows as 128 + its number (the shell's convention)
    std::string out;
};

// Runs a shell command, stderr merged into out.
Shell shell(const std::string& command) {
    Shell r{};
    FILE* pipe = ::popen(("( " + command + " ) 2>&1").c_str(), "r");
    REQUIRE(pipe != nullptr);
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
    const int status = ::pclose(pipe);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return r;
}

std::string pgi() {
    return std::string("'") + PGI_BINARY + "'";
}

// A scene file in the temporary directory, removed with the object.
class TempScene {
public:
    TempScene(const std::string& tag, const std::string& text)
        : path_(fs::temp_directory_path() / ("pgi_test_" + tag + "_" + std::to_string(::getpid()) + ".toml")) {
        std::ofstream(path_) << text;
    }
    ~TempScene() { fs::remove(path_); }
    std::string path() const { return std::string(1, '\'').append(path_.string()).append(1, '\''); }

private:
    fs::path path_;
};

std::string sum_of(std::size_t n) {
    std::string s;
    for (std::size_t i = 1; i <= n; ++i) s += (i > 1 ? "+x" : "x") + std::to_string(i);
    return s;
}

std::string coordinates(std::size_t n) {
    std::string s = "coordinates = [";
    for (std::size_t i = 1; i <= n; ++i) s += (i > 1 ? ", \"x" : "\"x") + std::to_string(i) + "\"";
    return s + "]\n";
}

// The n-site periodic Volterra lattice at order k, with a run: its exact phase takes seconds and
// about a gigabyte for n = 30, k = 6.
std::string volterra(std::size_t n, std::size_t k) {
    std::string s = "name = \"Volterra lattice\"\n" + coordinates(n) + "[brackets]\n";
    for (std::size_t i = 1; i <= n; ++i) {
        const std::size_t j = i % n + 1;
        s += "\"x" + std::to_string(i) + ",x" + std::to_string(j) + "\" = \"x" + std::to_string(i) + "*x" +
             std::to_string(j) + "\"\n";
    }
    s += "[hamiltonian]\nH = \"" + sum_of(n) + "\"\n[integrator]\norder = " + std::to_string(k) +
         "\ndt = \"1/20\"\n[run]\nx0 = [";
    for (std::size_t i = 1; i <= n; ++i) s += (i > 1 ? ", 1." : "1.") + std::to_string(i);
    return s + "]\nt_end = 1\n";
}

std::string power_scene(const std::string& H) {
    return "name = \"power\"\n" + coordinates(6) + "[brackets]\n\"x1,x2\" = \"1\"\n[hamiltonian]\nH = \"" + H + "\"\n";
}

}  // namespace

// issue 11.3
TEST_CASE("under a memory cap pgi ends with exit 4 or 5 and a message, never an abort") {
    if (address_sanitizer) return;
    // (x1+...+x6)^60 has 8.3 million terms, about 500 MB: above a 300 MB address space
    TempScene big("power60", power_scene(std::string(1, '(').append(sum_of(6)).append(")^60")));
    const std::string cap = "ulimit -v 300000; exec " + pgi() + " check " + big.path() + " --max-terms 1000000000";
    // the default budget (3/4 of the cap) refuses it before expanding: exit 4
    Shell budget = shell(cap);
    CHECK_MESSAGE(budget.exit_code == 4, budget.out);
    CHECK_MESSAGE(
        budget.out.find("hamiltonian.H: polynomial '(x1+x2+x3+x4+x5+x6)^60': expanding the '^' at position 20: the "
                        "power 60 of a 6-term polynomial could take ") != std::string::npos,
        budget.out);
    CHECK(budget.out.find("above the memory budget of 220 MB (raise it with --max-memory-mb or max_memory_mb)") != std::string::npos);
    // a budget above the cap lets FLINT run out of memory: exit 5 and a message, not SIGABRT (134)
    Shell oom = shell(cap + " --max-memory-mb 100000");
    CHECK_MESSAGE(oom.exit_code == 5, oom.out);
    CHECK(oom.out.rfind("pgi: out of memory: an allocation in the exact algebra failed", 0) == 0);
    // a real exact phase (the 30-site Volterra lattice's modified Hamiltonian through dt^8 at k = 6 grows past
    // 6 GB within a minute) is stopped by the memory budget between its operations
    TempScene lattice("volterra30", volterra(30, 6));
    Shell phase = shell("ulimit -v 300000; exec " + pgi() + " modified " + lattice.path() + " --upto 8");
    CHECK_MESSAGE(phase.exit_code == 4, phase.out);
    CHECK_MESSAGE(phase.out.find("exact phase stopped: ") != std::string::npos, phase.out);
    CHECK(phase.out.find("above the memory budget of 220 MB (raise it with --max-memory-mb or max_memory_mb)") != std::string::npos);
}

TEST_CASE("an explicit memory budget bounds the resident memory, whatever the address-space limit") {
    if (address_sanitizer) return;
    // under a loose limit, a run whose address space (40-50 MB above its resident memory) is above the budget but
    // whose resident memory is not runs
    Shell loose = shell("ulimit -v 8000000; exec " + pgi() + " integrate '" + PGI_SCENES_DIR + "/henon_heiles.toml'" +
                        " --t-end 1 --max-memory-mb 40");
    CHECK_MESSAGE(loose.exit_code == 0, loose.out);
}

// issue 11.3
TEST_CASE("a long exact phase shows progress on a terminal, --quiet silences it, --max-seconds stops it") {
    TempScene lattice("volterra30", volterra(30, 6));
    // script(1) gives pgi a terminal; the modified Hamiltonian through dt^8 runs more than a minute in a
    // release build, so a time budget of two seconds stops it after a progress line
    const std::string run = pgi() + " modified " + lattice.path() + " --upto 8 --max-seconds 2";
    Shell shown = shell(std::string("script -qec \"").append(run).append(" >/dev/null\" /dev/null"));
    CHECK_MESSAGE(shown.exit_code == 4, shown.out);
    CHECK_MESSAGE(shown.out.find("pgi: exact phase: ") != std::string::npos, shown.out);
    CHECK_MESSAGE(shown.out.find(" terms, 1") != std::string::npos, shown.out);  // "..., N terms, 1.0 s"
    CHECK(shown.out.find("above the time budget of 2 s (raise it with --max-seconds or max_seconds)") != std::string::npos);
    Shell quiet = shell(std::string("script -qec \"").append(run).append(" --quiet >/dev/null\" /dev/null"));
    CHECK_MESSAGE(quiet.exit_code == 4, quiet.out);
    CHECK_MESSAGE(quiet.out.find("pgi: exact phase: ") == std::string::npos, quiet.out);
    // without a terminal, no progress either
    Shell piped = shell(run + " >/dev/null");
    CHECK(piped.exit_code == 4);
    CHECK(piped.out.find("pgi: exact phase: ") == std::string::npos);
}

// issue 11.4
TEST_CASE("a huge power in a scene is refused at once with exit 4, naming the key and the position") {
    TempScene big("power1000", power_scene(std::string(1, '(').append(sum_of(6)).append(")^1000")));
    Shell r = shell(pgi() + " check " + big.path());
    CHECK_MESSAGE(r.exit_code == 4, r.out);
    CHECK_MESSAGE(
        r.out.find("hamiltonian.H: polynomial '(x1+x2+x3+x4+x5+x6)^1000': expanding the '^' at position 20: the "
                   "power 1000 of a 6-term polynomial could reach 8459043543951 terms, above the limit of 20000000") !=
            std::string::npos,
        r.out);
    CHECK_MESSAGE(r.out.find(big.path()) == r.out.rfind(big.path()), r.out);  // the file named once
    TempScene deep("deep", power_scene(std::string(100000, '-') + "x1"));
    Shell d = shell(pgi() + " check " + deep.path());
    CHECK_MESSAGE(d.exit_code == 2, d.out);
    CHECK(d.out.find("hamiltonian.H: malformed polynomial '") != std::string::npos);
    CHECK(d.out.find("nesting deeper than 200 (parentheses and signs) at position 201") != std::string::npos);
}
