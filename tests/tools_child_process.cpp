// The pgi program against what a hostile scene, a hostile local user or a signal can do to its child processes and
// its native-code cache: nothing in a scene or a path is run by gnuplot, a signal during compilation leaves no process
// and no temporary behind, and a cache directory another user prepared is refused.
#include "test_util.hpp"

#include <doctest/doctest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;

extern char** environ;

namespace {

// A fresh directory (mkdtemp) removed with what is in it.
struct Sandbox {
    fs::path path;
    explicit Sandbox(const std::string& tag) {
        std::string pattern = (fs::temp_directory_path() / ("pgi-test-" + tag + "-XXXXXX")).string();
        REQUIRE(::mkdtemp(pattern.data()) != nullptr);
        path = pattern;
    }
    ~Sandbox() {
        std::error_code ignored;  // (a destructor does not throw: a file gone meanwhile is no failure of the test)
        fs::remove_all(path, ignored);
    }
};

struct Ran {
    int exit_code;
    std::string err;
};

// Runs a shell command line (pgi's path is "$PGI") with stdout and stderr to files in dir.
Ran shell(const fs::path& dir, const std::string& line) {
    const fs::path out = dir / "stdout", err = dir / "stderr";
    const std::string cmd =
        "PGI='" + std::string(PGI_BINARY) + "'; " + line + " >'" + out.string() + "' 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    Ran r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, test::slurp(err)};
    fs::remove(out), fs::remove(err);
    return r;
}

// s as one word for sh: single-quoted, a ' written '\\''.
std::string sh_quote(const std::string& s) {
    std::string out = "'";
    for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

std::string harmonic(const std::string& name) {
    std::string text = test::slurp(test::scene_path("harmonic_oscillator"));
    const std::size_t at = text.find("name = ");
    const std::size_t end = text.find('\n', at);
    return text.replace(at, end - at, "name = " + name);
}

// Processes (not zombies) in process group pgid.
std::vector<pid_t> running_in_group(pid_t pgid) {
    std::vector<pid_t> found;
    for (const auto& e : fs::directory_iterator("/proc")) {
        const std::string name = e.path().filename().string();
        if (name.find_first_not_of("0123456789") != std::string::npos) continue;
        std::ifstream stat(e.path() / "stat");
        std::string line;
        if (!std::getline(stat, line)) continue;
        const std::size_t paren = line.rfind(')');
        if (paren == std::string::npos) continue;
        char state = 0;
        long ppid = 0, pgrp = 0;
        if (std::sscanf(line.c_str() + paren + 2, "%c %ld %ld", &state, &ppid, &pgrp) == 3 && pgrp == pgid &&
            state != 'Z')
            found.push_back(pid_t(std::stol(name)));
    }
    return found;
}

}  // namespace

TEST_CASE(
    "--plot: backquotes, system(), macros and quotes in a scene's name, its file name or the plot directory are text, "
    "never run") {
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        MESSAGE("gnuplot is not installed: not tested");
        return;
    }
    const Sandbox box("plot-injection");
    const std::string mark = (box.path / "PWNED").string();
    const std::string name = "\"body `touch " + mark + "1` system('touch " + mark + "2') @x $(touch " + mark +
                             "3) it''s \\\" ' . system(\\\"touch " + mark + "6\\\") . ' @title\"";
    const fs::path scene = box.path / "s`touch PWNED4`'.toml";  // a relative name: a file name holds no slash
    std::ofstream(scene) << harmonic(name);
    const fs::path figures = box.path / "figs `touch PWNED5` $(touch PWNED5) '";
    fs::create_directories(figures);
    const Ran r = shell(box.path, "cd " + sh_quote(box.path.string()) + " && \"$PGI\" integrate " +
                                      sh_quote(scene.string()) + " --t-end 2 --plot " + sh_quote(figures.string()));
    CHECK_MESSAGE(r.exit_code == 0, r.err);
    for (int i = 1; i <= 6; ++i) CHECK_FALSE(fs::exists(mark + std::to_string(i)));
    std::size_t drawn = 0;
    for (const auto& e : fs::directory_iterator(figures)) drawn += fs::file_size(e.path()) > 1000;
    CHECK(drawn == 4);
    // the title is drawn as written
    std::string svg;
    for (const auto& e : fs::directory_iterator(figures))
        if (e.path().extension() == ".svg") svg = test::slurp(e.path());
    CHECK(svg.find("`touch") != std::string::npos);
}

TEST_CASE(
    "--jit: a signal that ends pgi while the compiler runs (SIGTERM, SIGINT, a closed terminal's SIGHUP) kills its "
    "process group, removes the temporaries, exits 128 + the signal") {
    for (const int sig : {SIGTERM, SIGINT, SIGHUP}) {
        CAPTURE(sig);
        const Sandbox box("jit-signal");
        const fs::path cache = box.path / "cache", pid_file = box.path / "compiler.pid",
                       compiler = box.path / "slow-cc";
        // every compiler pgi starts (one per core, on threads of their own) lists its pid; the first also names it
        const fs::path all = box.path / "compilers";
        std::ofstream(compiler) << "#!/bin/sh\necho $$ >> '" << all.string() << "'\necho $$ > '" << pid_file.string()
                                << ".tmp'\nmv '" << pid_file.string() << ".tmp' '" << pid_file.string()
                                << "'\nsleep 30\n";
        fs::permissions(compiler, fs::perms::owner_all);
        const std::string scene = test::scene_path("harmonic_oscillator");
        const std::string cache_env = "PGI_JIT_CACHE=" + cache.string(), cxx_env = "PGI_CXX=" + compiler.string();
        std::vector<std::string> env{cache_env, cxx_env};
        for (char** e = environ; *e; ++e)
            if (std::string(*e).rfind("PGI_", 0) != 0) env.push_back(*e);
        std::vector<char*> envp, argv;
        for (std::string& e : env) envp.push_back(e.data());
        envp.push_back(nullptr);
        std::vector<std::string> args{PGI_BINARY, "integrate", scene, "--jit", "--t-end", "1"};
        for (std::string& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, 1, (box.path / "out").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
        posix_spawn_file_actions_addopen(&actions, 2, (box.path / "err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
        pid_t pgi = 0;
        REQUIRE(::posix_spawn(&pgi, PGI_BINARY, &actions, nullptr, argv.data(), envp.data()) == 0);
        posix_spawn_file_actions_destroy(&actions);
        for (int i = 0; i < 3000 && !fs::exists(pid_file); ++i) ::usleep(20000);
        REQUIRE_MESSAGE(fs::exists(pid_file), test::slurp(box.path / "err"));
        pid_t compiler_pid = 0;
        std::ifstream(pid_file) >> compiler_pid;
        REQUIRE(compiler_pid > 0);
        REQUIRE_FALSE(running_in_group(compiler_pid).empty());  // the compiler's own group: it and its sleep
        bool temporaries = false;
        for (const auto& e : fs::directory_iterator(cache)) temporaries = temporaries || e.path().extension() == ".cpp";
        CHECK(temporaries);  // the source being compiled
        ::kill(pgi, sig);
        int status = 0;
        REQUIRE(::waitpid(pgi, &status, 0) == pgi);
        CHECK(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) == 128 + sig);
        // no compiler outlives pgi, the one started while the signal came included
        std::ifstream listed(all);
        for (pid_t group = 0; listed >> group;) {
            CAPTURE(group);
            std::vector<pid_t> left = running_in_group(group);
            for (int i = 0; i < 100 && !left.empty(); ++i) ::usleep(20000), left = running_in_group(group);
            CHECK(left.empty());
        }
        for (const auto& e : fs::directory_iterator(cache)) FAIL("left in the cache: " << e.path());
    }
}

TEST_CASE(
    "--jit as an unprivileged user: a cache directory another user prepared is refused (exit 7), the fallback too") {
    if (::geteuid() != 0) {
        MESSAGE("not root: cannot switch users, not tested");
        return;
    }
    if (std::system("command -v setpriv >/dev/null 2>&1") != 0) {
        MESSAGE("setpriv (util-linux) is missing: not tested");
        return;
    }
    const passwd* nobody = ::getpwnam("nobody");
    REQUIRE(nobody != nullptr);
    const std::string uid = std::to_string(nobody->pw_uid);
    const Sandbox box("jit-foreign");
    fs::permissions(box.path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
    const fs::path scene = box.path / "s.toml";
    std::ofstream(scene) << test::slurp(test::scene_path("harmonic_oscillator"));
    fs::permissions(scene,
                    fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
    // prepared by root for the victim: world-writable, with a library planted under a name the victim may compute
    const fs::path planted = box.path / "shared-cache";
    fs::create_directories(planted);
    fs::permissions(planted, fs::perms::all);
    std::ofstream(planted / "0123456789abcdef.so") << "planted";
    const fs::path tmp = box.path / "tmp";  // a system temporary directory: sticky, world-writable
    fs::create_directories(tmp / ("pgi-jit-" + uid));
    ::chmod(tmp.c_str(), 01777);
    fs::permissions(tmp / ("pgi-jit-" + uid), fs::perms::all);
    const std::string as_nobody =
        "cd '" + box.path.string() +
        "' && setpriv --reuid=nobody --regid=nogroup --clear-groups env -u PGI_CXX -u CXX -u XDG_CACHE_HOME ";
    const std::string run = " \"$PGI\" integrate s.toml --jit --t-end 1";
    // a checkout under a private directory (mktemp -d) cannot be run by nobody at all: nothing to test there
    if (shell(box.path, "setpriv --reuid=nobody --regid=nogroup --clear-groups test -x \"$PGI\"").exit_code != 0) {
        MESSAGE("nobody cannot run pgi here (a directory above it is private): not tested");
        return;
    }
    const Ran named = shell(box.path, as_nobody + "PGI_JIT_CACHE='" + planted.string() + "' HOME=/nonexistent" + run);
    CHECK(named.exit_code == 7);
    CHECK_MESSAGE(named.err.find(planted.string() + ": it is owned by uid 0, not by the effective user (uid " + uid +
                                 ")") != std::string::npos,
                  named.err);
    const Ran fallback =
        shell(box.path, as_nobody + "-u PGI_JIT_CACHE HOME=/nonexistent TMPDIR='" + tmp.string() + "'" + run);
    CHECK(fallback.exit_code == 7);
    CHECK_MESSAGE(fallback.err.find("pgi-jit-" + uid + ": it is owned by uid 0") != std::string::npos, fallback.err);
    // the victim's own fallback, made by pgi: 0700, and used
    fs::remove_all(tmp / ("pgi-jit-" + uid));
    const Ran own =
        shell(box.path, as_nobody + "-u PGI_JIT_CACHE HOME=/nonexistent TMPDIR='" + tmp.string() + "'" + run);
    CHECK_MESSAGE(own.exit_code == 0, own.err);
    struct stat st {};
    REQUIRE(::stat((tmp / ("pgi-jit-" + uid)).c_str(), &st) == 0);
    CHECK(st.st_uid == nobody->pw_uid);
    CHECK((st.st_mode & 07777) == 0700);
    CHECK(test::slurp(planted / "0123456789abcdef.so") == "planted");
}
