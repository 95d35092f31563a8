#include "series/detail/child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <system_error>

extern char** environ;

namespace pgi {

namespace {

// What a signal handler must undo, in a fixed table: the handler may call only async-signal-safe functions (no
// allocation, no lock), so paths are C strings copied in and slots are claimed with lock-free atomics. NOTE: the one
// piece of global mutable state here; a signal handler has no other way to find the children and temporaries.
struct SignalTable {
    static constexpr int files = 64, groups = 32;
    std::atomic<int> file_state[files];  // 0 free, 1 being written, 2 registered
    char path[files][4096];
    std::atomic<pid_t> group[groups];  // 0 free, else a running child's process group
    // Spawns under way on other threads (spawn_registered), and whether the handler has begun: a child spawned but not
    // yet registered when the signal came would outlive the program, so the handler waits for those to register
    // (their threads hold the signals back), and none starts once it has begun.
    std::atomic<int> spawning;
    std::atomic<bool> exiting;
};
SignalTable table{};  // constant-initialised: safe to read in a handler at any time

// The signals whose default action ends the process, and on which pgi ends it itself, its children killed and its
// temporaries removed: an interrupt, a termination, a closed terminal (SIGHUP), a quit, and the timers, user signals
// and CPU limit a supervisor may send. (Not SIGPIPE and SIGXFSZ, which the CLI ignores so that a write fails with exit
// 6; not the profilers' SIGPROF and SIGVTALRM.)
constexpr int ending_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGALRM, SIGUSR1, SIGUSR2, SIGXCPU};

// The ending signals, held back in a handler and while a child is spawned and registered.
sigset_t ending_set() {
    sigset_t set;
    sigemptyset(&set);
    for (int sig : ending_signals) sigaddset(&set, sig);
    return set;
}

static_assert(std::atomic<int>::is_always_lock_free && std::atomic<pid_t>::is_always_lock_free &&
              std::atomic<bool>::is_always_lock_free);

int register_file(const std::string& path) {
    if (path.size() >= sizeof table.path[0]) return -1;
    for (int i = 0; i < SignalTable::files; ++i) {
        int expected = 0;
        if (table.file_state[i].compare_exchange_strong(expected, 1)) {
            std::memcpy(table.path[i], path.c_str(), path.size() + 1);
            table.file_state[i].store(2);
            return i;
        }
    }
    return -1;
}

int register_group(pid_t pgid) {
    for (int i = 0; i < SignalTable::groups; ++i) {
        pid_t expected = 0;
        if (table.group[i].compare_exchange_strong(expected, pgid)) return i;
    }
    return -1;
}

extern "C" void kill_children_remove_temporaries_and_exit(int sig) {
    table.exiting.store(true);
    // a spawn under way registers within microseconds (its thread blocks no more than that); a second at most
    const timespec pause{0, 1'000'000};
    for (int i = 0; i < 1000 && table.spawning.load() != 0; ++i) ::nanosleep(&pause, nullptr);
    for (auto& g : table.group)
        if (const pid_t pgid = g.load(); pgid > 0) ::kill(-pgid, SIGKILL);
    for (int i = 0; i < SignalTable::files; ++i)
        if (table.file_state[i].load() == 2) ::unlink(table.path[i]);
    ::_exit(128 + sig);  // 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP..., as the shell reports a signal
}

void install_handler(int sig) {
    struct sigaction sa {};
    sa.sa_handler = kill_children_remove_temporaries_and_exit;
    sa.sa_mask = ending_set();
    ::sigaction(sig, &sa, nullptr);
}

// Where an ending signal would simply end the process (a C++ program using the library), the handler takes over, so
// that a child is not left running without its parent; a handler someone installed (Python's, the CLI's) is kept.
void install_handler_where_default() {
    for (int sig : ending_signals) {
        struct sigaction current {};
        if (::sigaction(sig, nullptr, &current) == 0 && current.sa_handler == SIG_DFL &&
            !(current.sa_flags & SA_SIGINFO))
            install_handler(sig);
    }
}

// A file descriptor closed when it goes out of scope.
struct Fd {
    int fd = -1;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

// Appends what the pipe holds now to out, keeping its last limit bytes; false at end of file or on an error.
bool drain(int fd, std::string& out, std::size_t limit) {
    char buffer[16384];
    for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return n < 0 && errno == EAGAIN;
        out.append(buffer, std::size_t(n));
        if (out.size() > 2 * limit) out.erase(0, out.size() - limit);
    }
}

// The spawn attributes: a process group of its own (pgid = its pid), no blocked signal, and the default action for
// the signals pgi handles or ignores (SIGPIPE is ignored by the CLI).
struct SpawnSetup {
    posix_spawnattr_t attr;
    posix_spawn_file_actions_t actions;
    SpawnSetup(int output) {
        posix_spawnattr_init(&attr);
        posix_spawnattr_setpgroup(&attr, 0);
        sigset_t none;
        sigemptyset(&none);
        sigset_t defaults = ending_set();  // (exec resets the handled ones; the ignored ones would stay ignored)
        for (int sig : {SIGPIPE, SIGXFSZ}) sigaddset(&defaults, sig);
        posix_spawnattr_setsigmask(&attr, &none);
        posix_spawnattr_setsigdefault(&attr, &defaults);
        posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
        posix_spawn_file_actions_adddup2(&actions, output, 1);
        posix_spawn_file_actions_adddup2(&actions, output, 2);
    }
    ~SpawnSetup() {
        posix_spawn_file_actions_destroy(&actions);
        posix_spawnattr_destroy(&attr);
    }
};

// Spawns argv with the ending signals held back on this thread until its group is registered, and counted in
// table.spawning for a handler running on another thread meanwhile (a signal in between would leave it running);
// returns the pid (the group's id) and the slot, or the spawn error.
int spawn_registered(const std::vector<std::string>& argv, int output, pid_t& pid, int& slot) {
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const sigset_t held = ending_set();
    sigset_t previous;
    ::pthread_sigmask(SIG_BLOCK, &held, &previous);
    table.spawning.fetch_add(1);
    int spawned = ECANCELED;  // (the handler has begun on another thread: it is about to end the program)
    if (!table.exiting.load()) {
        const SpawnSetup setup(output);
        spawned = ::posix_spawnp(&pid, args[0], &setup.actions, &setup.attr, args.data(), environ);
        if (spawned == 0) slot = register_group(pid);
    }
    table.spawning.fetch_sub(1);
    ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
    return spawned;
}

std::string how_it_ended(int status) {
    if (WIFEXITED(status))
        return WEXITSTATUS(status) == 0 ? "" : "exited with status " + std::to_string(WEXITSTATUS(status));
    if (WIFSIGNALED(status)) return "was killed by signal " + std::to_string(WTERMSIG(status));
    return "ended with wait status " + std::to_string(status);
}

}  // namespace

ChildResult run_child(const std::vector<std::string>& argv, const ChildOptions& options) {
    install_handler_where_default();
    Fd read_end, write_end;
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw std::system_error(errno, std::generic_category(), "pipe");
    read_end.fd = fds[0], write_end.fd = fds[1];
    ::fcntl(read_end.fd, F_SETFL, O_NONBLOCK);
    pid_t pid = 0;
    int slot = -1;
    ChildResult result;
    if (const int e = spawn_registered(argv, write_end.fd, pid, slot); e != 0) {
        result.failure = "cannot be run (" + std::string(std::strerror(e)) + ")";
        return result;
    }
    ::close(write_end.fd), write_end.fd = -1;  // the child's copies are the only writers left
    const auto deadline = std::chrono::steady_clock::now() + options.timeout;
    bool open = true, timed_out = false, cancelled = false;
    for (;;) {
        pollfd p{read_end.fd, POLLIN, 0};
        if (open && ::poll(&p, 1, 20) > 0) open = drain(read_end.fd, result.output, options.output_limit);
        siginfo_t info{};
        if (::waitid(P_PID, id_t(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid) break;
        // output closed (at the child's exit, or it closed it, or a grandchild holds it): only the exit is awaited,
        // looked at again in 5 ms (a compiler's end was seen 20 ms late when this slept first)
        if (!open) ::usleep(5000);
        if (std::chrono::steady_clock::now() > deadline) {
            timed_out = true;
            break;
        }
        if (options.cancel && options.cancel->load(std::memory_order_relaxed)) {
            cancelled = true;
            break;
        }
    }
    // the leader is a zombie or still running: its id cannot be reused yet, so the group it names is still its own
    ::kill(-pid, SIGKILL);
    if (open) drain(read_end.fd, result.output, options.output_limit);
    if (slot >= 0) table.group[slot].store(0);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (result.output.size() > options.output_limit)
        result.output.erase(0, result.output.size() - options.output_limit);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(options.timeout).count();
    result.failure =
        cancelled   ? std::string("was cancelled")
        : timed_out ? "stopped after " + (ms % 1000 ? std::to_string(ms) + " ms" : std::to_string(ms / 1000) + " s")
                    : how_it_ended(status);
    return result;
}

TemporaryFile::TemporaryFile(std::string path) : path_(std::move(path)), slot_(register_file(path_)) {}

TemporaryFile::~TemporaryFile() {
    if (!kept_) ::unlink(path_.c_str());
    keep();
}

void TemporaryFile::keep() {
    if (slot_ >= 0) table.file_state[slot_].store(0);
    slot_ = -1;
    kept_ = true;
}

void end_cleanly_on_signals() {
    for (int sig : ending_signals) install_handler(sig);
}

}  // namespace pgi
