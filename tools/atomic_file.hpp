#pragma once
// AtomicFile: output written beside its target and renamed into place by commit(), so a reader
// never sees half a file; an uncommitted file is removed by the destructor.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

namespace pgi {

class AtomicFile {
public:
    /// Throws std::invalid_argument naming the path when its directory does not exist or the file cannot be created.
    explicit AtomicFile(std::filesystem::path target)
        : target_(std::move(target)), temp_(target_.string() + ".tmp" + std::to_string(::getpid())) {
        const auto dir = target_.has_parent_path() ? target_.parent_path() : std::filesystem::path(".");
        if (!std::filesystem::is_directory(dir))
            throw std::invalid_argument(target_.string() + ": cannot write: directory '" + dir.string() + "' does not exist");
        out_.open(temp_, std::ios::binary | std::ios::trunc);
        if (!out_) throw std::invalid_argument(target_.string() + ": cannot write the file");
    }
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;
    ~AtomicFile() {
        if (!committed_) {
            out_.close();
            std::error_code ec;
            std::filesystem::remove(temp_, ec);
        }
    }

    std::ofstream& stream() { return out_; }

    /// Flushes and renames into place. Throws std::runtime_error if the data could not be written.
    void commit() {
        out_.flush();
        if (!out_) throw std::runtime_error(target_.string() + ": write failed");
        out_.close();
        std::filesystem::rename(temp_, target_);
        committed_ = true;
    }

private:
    std::filesystem::path target_, temp_;
    std::ofstream out_;
    bool committed_ = false;
};

}  // namespace pgi
