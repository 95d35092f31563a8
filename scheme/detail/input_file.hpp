#pragma once
// The input half of pgi's file policy (the output half is tools/atomic_file.hpp): every file pgi reads as
// input (a scene, an ensemble's states) is opened without blocking, must be a regular file and is read whole
// up to a bound, so a FIFO, a device or a link to one never hangs or floods a run.
#include <cstddef>
#include <filesystem>
#include <string>

namespace pgi {

/// The whole of path, read under the input rules: opened with O_NONBLOCK (a FIFO never waits for a writer),
/// a regular file only (not a directory, FIFO or device, also through a link), at most max_bytes. what names the
/// kind of file in messages ("scene", "states"). Throws InputError (key: the path) naming the problem.
std::string read_input_file(const std::filesystem::path& path, std::size_t max_bytes, const std::string& what);

}  // namespace pgi
