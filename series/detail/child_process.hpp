#pragma once
// The one way pgi runs another program (the compiler for native code, gnuplot for figures), and what a signal must
// undo. A child gets an argv (no shell: nothing in it is interpreted), a process group of its own, /dev/null as its
// input, and a bounded capture of its output; past its time-out the whole group is killed and reaped. On a signal
// that ends the process (SIGINT, SIGTERM, SIGHUP, ...: end_cleanly_on_signals) the running children's groups are
// killed and the registered temporary files removed before pgi ends with 128 + the signal (the CLI's handler, or the
// one run_child installs where the signal's action is the default one).
#include <atomic>
#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

namespace pgi {

struct ChildOptions {
    /// The child's process group is killed (SIGKILL) past this.
    std::chrono::milliseconds timeout{std::chrono::minutes(5)};
    /// At most this many of the last bytes of its output (stdout and stderr together) are kept.
    std::size_t output_limit = std::size_t(64) << 10;
    /// When set, polled while the child runs: once true, its group is killed and run_child returns "was cancelled"
    /// (a background build nobody waits for any more, series/native.hpp).
    const std::atomic<bool>* cancel = nullptr;
};

struct ChildResult {
    /// "" when the child exited with status 0; else what happened ("cannot be run (...)", "exited with status 1",
    /// "was killed by signal 9", "stopped after 300 s", "was cancelled").
    std::string failure;
    /// The tail of its output, raw: pass it through output_tail() (series/message.hpp) before showing it.
    std::string output;
    bool ok() const { return failure.empty(); }
};

/// Runs argv (argv[0] searched on PATH) as described above and waits for it; when it ends, whatever its group still
/// holds is killed too, so no process is left behind. Requires a non-empty argv. Throws std::system_error only when
/// no pipe can be made.
ChildResult run_child(const std::vector<std::string>& argv, const ChildOptions& options = {});

/// A file pgi is creating, removed by the destructor unless keep() was called, and by the signal handler if a signal
/// ends pgi first. The path is registered in a fixed table (64 at once; beyond, only the destructor).
class TemporaryFile {
public:
    explicit TemporaryFile(std::string path);
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    ~TemporaryFile();
    const std::string& path() const { return path_; }
    /// The file is no longer a temporary (renamed into place, or removed by the caller): neither removes it.
    void keep();

private:
    std::string path_;
    int slot_ = -1;
    bool kept_ = false;
};

/// Installs the handler for the signals that end a process (SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGALRM, SIGUSR1,
/// SIGUSR2, SIGXCPU) that kills the running children's groups, removes the registered temporaries and ends the process
/// with 128 + the signal (130, 143, 129, ...). The CLI calls it first thing.
void end_cleanly_on_signals();

}  // namespace pgi
