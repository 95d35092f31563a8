#include "tools/program_allocator.hpp"

#ifdef PGI_MIMALLOC
#include <mimalloc.h>
#endif

namespace pgi {

std::string program_allocator() {
#ifdef PGI_MIMALLOC
    // mi_version() is also what keeps libmimalloc among the program's needed libraries (its malloc then
    // replaces the C library's for the whole process) under a linker that drops unreferenced ones
    const int v = mi_version();
    return "mimalloc " + std::to_string(v / 100) + "." + std::to_string(v % 100 / 10) + "." + std::to_string(v % 10);
#else
    return "the system malloc";
#endif
}

}  // namespace pgi
