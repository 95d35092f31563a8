#pragma once
// The allocator pgi's programs run on (CMakeLists.txt, PGI_MIMALLOC): linked into the command line, the
// benchmarks and the peers only, never into the library, which leaves its host's malloc alone.
#include <string>

namespace pgi {

/// "mimalloc X.Y.Z" when the program links mimalloc, else "the system malloc".
std::string program_allocator();

}  // namespace pgi
