#pragma once
// AtomicFile: output written to a fresh temporary file beside its target (created exclusively, with an
// unpredictable name, never through a link), flushed to disk and renamed into place by commit(), so a
// reader never sees half a file; an uncommitted file is removed by the destructor, and by
// the signal handler (series/detail/child_process.hpp) when a signal (SIGINT, SIGTERM, SIGHUP, ...) ends the program.
#include "series/detail/child_process.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace pgi {

/// Writing the output failed (closed pipe, full disk, ...): exit code 6.
class OutputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

namespace detail {

// A stream buffer over a file descriptor that remembers the first failed write.
class FdBuffer : public std::streambuf {
public:
    explicit FdBuffer(int fd) : fd_(fd) { setp(buffer_, buffer_ + sizeof buffer_); }
    bool failed() const { return failed_; }

protected:
    int_type overflow(int_type c) override {
        if (!drain()) return traits_type::eof();
        if (!traits_type::eq_int_type(c, traits_type::eof())) sputc(traits_type::to_char_type(c));
        return traits_type::not_eof(c);
    }
    int sync() override { return drain() ? 0 : -1; }

private:
    bool drain() {
        const char* p = pbase();
        while (!failed_ && p < pptr()) {
            const ssize_t n = ::write(fd_, p, static_cast<std::size_t>(pptr() - p));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0)
                failed_ = true;
            else
                p += n;
        }
        setp(buffer_, buffer_ + sizeof buffer_);
        return !failed_;
    }
    int fd_;
    bool failed_ = false;
    char buffer_[1 << 16];
};

inline std::filesystem::path directory_of(const std::filesystem::path& target) {
    return target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
}

}  // namespace detail

/// Installs the handler that removes the temporary files of unfinished AtomicFiles (and of native code) and kills
/// running child processes on the signals that end a process (SIGINT, SIGTERM, SIGHUP, ...), then exits with 128 + the
/// signal number (130, 143, 129, ...).
inline void remove_temporaries_on_signals() {
    end_cleanly_on_signals();
}

/// Whether target can receive an output file, checked before any work: its directory exists and is
/// writable, and the target is absent or a regular file (not a directory, FIFO or device) that is not
/// one of the inputs (the same inode: --csv naming the scene file would overwrite it). Throws
/// std::invalid_argument (bad input, exit 2) naming the path and the problem.
inline void check_output_path(const std::filesystem::path& target,
                              const std::vector<std::filesystem::path>& inputs = {}) {
    const std::string name = target.string();
    const auto dir = detail::directory_of(target);
    if (name.empty() || target.filename().empty() || target.filename() == "." || target.filename() == "..")
        throw std::invalid_argument("'" + name + "': cannot write: not a file name");
    struct stat d {};
    if (::stat(dir.c_str(), &d) != 0 || !S_ISDIR(d.st_mode))
        throw std::invalid_argument(name + ": cannot write: directory '" + dir.string() + "' does not exist");
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
        throw std::invalid_argument(name + ": cannot write: directory '" + dir.string() + "' is not writable");
    struct stat t {};
    if (::stat(target.c_str(), &t) != 0) return;  // absent (or a dangling link, which the rename replaces)
    if (!S_ISREG(t.st_mode))
        throw std::invalid_argument(name + ": cannot write: it exists and is not a regular file (" +
                                    (S_ISDIR(t.st_mode)    ? "a directory"
                                     : S_ISFIFO(t.st_mode) ? "a FIFO"
                                                           : "a device or special file") +
                                    ")");
    for (const auto& in : inputs) {
        struct stat s {};
        if (::stat(in.c_str(), &s) == 0 && s.st_dev == t.st_dev && s.st_ino == t.st_ino)
            throw std::invalid_argument(name + ": cannot write: it is the input file " + in.string());
    }
}

class AtomicFile {
public:
    /// Checks the target (check_output_path) and creates the temporary file. Throws std::invalid_argument
    /// naming the path when it cannot be an output.
    explicit AtomicFile(std::filesystem::path target, const std::vector<std::filesystem::path>& inputs = {})
        : target_(std::move(target)) {
        check_output_path(target_, inputs);
        std::string temp_name = ".";
        temp_name += target_.filename().string();
        temp_name += ".tmp.XXXXXX";
        std::string pattern = (detail::directory_of(target_) / temp_name).string();
        fd_ = ::mkostemp(pattern.data(), O_CLOEXEC);  // O_CREAT | O_EXCL: a link or any existing file is never followed
        if (fd_ < 0)
            throw std::invalid_argument(target_.string() + ": cannot write the file (" + std::strerror(errno) + ")");
        temp_ = pattern;
        const mode_t mask = ::umask(0);  // the permissions an ordinary new file would get (mkostemp gives 0600)
        ::umask(mask);
        ::fchmod(fd_, 0666 & ~mask);
        temp_file_ = std::make_unique<TemporaryFile>(temp_);
        buffer_ = std::make_unique<detail::FdBuffer>(fd_);
        stream_ = std::make_unique<std::ostream>(buffer_.get());
    }
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;
    ~AtomicFile() {
        if (fd_ >= 0) ::close(fd_);  // temp_file_ removes the file unless committed
    }

    std::ostream& stream() { return *stream_; }

    /// Flushes to disk (fsync) and closes, the target not yet touched. Throws OutputError if the data could not be
    /// written. (commit() does it when not done.)
    void finish() {
        if (fd_ >= 0) flush_and_close();
    }

    /// Flushes to disk (fsync) and renames into place. Throws OutputError if the data could not be written.
    void commit() {
        finish();
        if (::rename(temp_.c_str(), target_.c_str()) != 0)
            throw OutputError(target_.string() + ": cannot rename the written file into place (" +
                              std::strerror(errno) + ")");
        temp_file_->keep();
    }

    /// As commit(), but never replaces a file: link(2) gives the target its name only if the name is free. Throws
    /// OutputError if the target exists by then (the temporary is removed, the existing file left as it was).
    void commit_new() {
        finish();
        if (::link(temp_.c_str(), target_.c_str()) != 0)
            throw OutputError(target_.string() + (errno == EEXIST ? ": exists (written meanwhile?): not replaced"
                                                                  : ": cannot give the written file its name (" +
                                                                        std::string(std::strerror(errno)) + ")"));
        ::unlink(temp_.c_str());
        temp_file_->keep();
    }

private:
    void flush_and_close() {  // (once: fd_ is then closed)
        stream_->flush();
        const bool written = *stream_ && !buffer_->failed() && ::fsync(fd_) == 0;
        const int saved = errno;
        const bool closed = ::close(fd_) == 0;
        fd_ = -1;
        if (!written || !closed)
            throw OutputError(target_.string() + ": write failed (" + std::strerror(written ? errno : saved) + ")");
    }

    std::filesystem::path target_;
    std::string temp_;
    int fd_ = -1;
    std::unique_ptr<TemporaryFile> temp_file_;
    std::unique_ptr<detail::FdBuffer> buffer_;
    std::unique_ptr<std::ostream> stream_;
};

/// Commits a set of files that belong together (an ensemble's arrays and table): every one is written to disk before
/// any is renamed, so a write that fails (a full disk, a file-size limit) leaves every target as it was, never some
/// old and some new.
inline void commit_all(const std::vector<std::unique_ptr<AtomicFile>>& files) {
    for (const auto& f : files) f->finish();
    for (const auto& f : files) f->commit();
}

}  // namespace pgi
