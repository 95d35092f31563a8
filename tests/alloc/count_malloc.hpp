#pragma once
// glibc's malloc, counted while `counting` is set (Eigen and FLINT allocate through it, as does operator new).
// Included by exactly one translation unit of each allocation-test program: it defines malloc itself.
#include <cstddef>

extern "C" void* __libc_malloc(std::size_t);
namespace {
long allocations = 0;
bool counting = false;
}  // namespace
extern "C" void* malloc(std::size_t n) {
    if (counting) ++allocations;
    return __libc_malloc(n);
}
