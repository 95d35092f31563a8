#include "scheme/detail/input_file.hpp"

#include "scheme/input.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace pgi {

namespace {

// Closes a descriptor when it leaves scope.
struct Descriptor {
    int fd;
    ~Descriptor() {
        if (fd >= 0) ::close(fd);
    }
};

std::string cannot_read() {
    return std::string("cannot read the file (") + std::strerror(errno) + ")";
}

}  // namespace

std::string read_input_file(const std::filesystem::path& path, std::size_t max_bytes, const std::string& what) {
    const std::string name = path.string();
    const Descriptor d{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
    if (d.fd < 0) throw InputError(name, cannot_read());
    struct stat st {};
    if (::fstat(d.fd, &st) != 0) throw InputError(name, cannot_read());
    if (S_ISDIR(st.st_mode)) throw InputError(name, "is a directory, not a " + what + " file");
    if (!S_ISREG(st.st_mode)) throw InputError(name, "is not a regular file (a FIFO or device?)");
    if (std::size_t(st.st_size) > max_bytes)
        throw InputError(name, "the file has " + std::to_string(st.st_size) + " bytes, above the limit of " +
                                   std::to_string(max_bytes) + " for a " + what + " file");
    std::string text(std::size_t(st.st_size), '\0');
    std::size_t got = 0;
    while (got < text.size()) {
        const ssize_t n = ::read(d.fd, text.data() + got, text.size() - got);
        if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
        if (n < 0) throw InputError(name, cannot_read());
        if (n == 0) break;  // shrank while read
        got += std::size_t(n);
    }
    text.resize(got);
    return text;
}

}  // namespace pgi
