// Child processes (series/detail/child_process.hpp) and the message rule (series/message.hpp): a child's output is
// bounded, its group killed past the time-out with everything it started, its status reported; diagnostics one bounded
// line.
#include "series/detail/child_process.hpp"
#include "series/message.hpp"

#include <doctest/doctest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include <signal.h>
#include <unistd.h>

using namespace pgi;
namespace fs = std::filesystem;

namespace {

// Whether process pid is gone (or a zombie waiting for init): nothing of it runs.
bool gone(pid_t pid) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(stat, line)) return true;
    const std::size_t paren = line.rfind(')');
    return paren != std::string::npos && line.size() > paren + 2 && line[paren + 2] == 'Z';
}

// Whether the process whose pid a child wrote to the file pids is gone within two seconds; the file is removed.
bool background_gone(const fs::path& pids) {
    pid_t background = 0;
    std::ifstream(pids) >> background;
    fs::remove(pids);
    if (background <= 0) return false;
    for (int i = 0; i < 100 && !gone(background); ++i) ::usleep(20000);
    return gone(background);
}

}  // namespace

TEST_CASE("child process: its status and the tail of its output, stdin empty, no shell between") {
    ChildResult ok = run_child({"sh", "-c", "cat; echo out; echo err >&2"});
    CHECK(ok.ok());
    CHECK(ok.output == "out\nerr\n");  // cat read /dev/null: nothing
    ChildResult failed = run_child({"sh", "-c", "exit 3"});
    CHECK(failed.failure == "exited with status 3");
    ChildResult missing = run_child({"/nonexistent/pgi-program"});
    CHECK(missing.failure.rfind("cannot be run (", 0) == 0);
    // an argument is an argument: nothing in it runs
    const fs::path marker = fs::temp_directory_path() / ("pgi-child-marker-" + std::to_string(::getpid()));
    ChildResult echoed = run_child({"echo", "`touch " + marker.string() + "`", "$(touch " + marker.string() + ")"});
    CHECK(echoed.ok());
    CHECK_FALSE(fs::exists(marker));
}

TEST_CASE("child process: 100 MB of output is kept as its last 64 KiB") {
    ChildResult r = run_child({"sh", "-c", "head -c 100000000 /dev/zero | tr '\\000' 'x'; echo; echo the end"});
    CHECK(r.ok());
    CHECK(r.output.size() == ChildOptions{}.output_limit);
    CHECK(r.output.substr(r.output.size() - 8) == "the end\n");
}

TEST_CASE("child process: past its time-out its whole group is killed, what it started included, and reaped") {
    const fs::path pids = fs::temp_directory_path() / ("pgi-child-pids-" + std::to_string(::getpid()));
    const auto start = std::chrono::steady_clock::now();
    ChildResult r = run_child({"sh", "-c", "sleep 30 & echo $! > '" + pids.string() + "'; sleep 30"},
                              {.timeout = std::chrono::milliseconds(300)});
    const auto took = std::chrono::steady_clock::now() - start;
    CHECK(took < std::chrono::seconds(10));
    CHECK(r.failure == "stopped after 300 ms");
    CHECK(background_gone(pids));
}

TEST_CASE("child process: a child that ends leaves nothing running behind it") {
    const fs::path pids = fs::temp_directory_path() / ("pgi-child-left-" + std::to_string(::getpid()));
    ChildResult r = run_child({"sh", "-c", "sleep 30 > /dev/null 2>&1 & echo $! > '" + pids.string() + "'"});
    CHECK(r.ok());
    CHECK(background_gone(pids));
}

TEST_CASE("child process: a temporary file is removed unless kept") {
    const fs::path p = fs::temp_directory_path() / ("pgi-child-temp-" + std::to_string(::getpid()));
    {
        std::ofstream(p) << "x";
        TemporaryFile t(p.string());
    }
    CHECK_FALSE(fs::exists(p));
    {
        std::ofstream(p) << "x";
        TemporaryFile t(p.string());
        t.keep();
    }
    CHECK(fs::exists(p));
    fs::remove(p);
}

TEST_CASE("message: printable shows every control character as \\xNN; output_tail keeps the last lines, bounded") {
    CHECK(printable(std::string("a\x1b[31mb\0c\n\x7f", 11)) == "a\\x1b[31mb\\x00c\\x0a\\x7f");
    CHECK(output_tail("one\ntwo\n\nthree\r\n", 2) == "two | three");
    const std::string tail = output_tail(std::string(100000, 'x') + "\nend\x1b\n");
    CHECK(tail.size() <= 1500);
    CHECK(tail.substr(tail.size() - 7) == "end\\x1b");
    CHECK(tail.rfind("...", 0) == 0);
}
