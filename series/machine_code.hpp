#pragma once
// Machine code for compiled maps, written in memory at once: no compiler, no file, no cache. A CompiledMap's tape as
// x86-64 AVX instructions (Xbyak encodes them): the interpreter's index loads and loop control disappear, as in native
// code (series/native.hpp), but the code exists microseconds after the map does, so every run gets it, however short.
// Every output is formed by the interpreter's operations in the interpreter's order (the same monomial products, the
// same four partial sums and their pairing, separate multiplies and adds), so the outputs are the interpreter's, bit
// for bit, as native code's are, but for a NaN's payload and sign where two NaNs meet in a product (x86 keeps the first
// operand's, and neither this code nor a compiler keeps the interpreter's operand order). Native code, where the cache
// keeps it or a long run builds it, still runs first: the compiler allocates every register, where this code keeps
// the products on the stack and the values read again in the registers a phase leaves free.
#include "series/compile.hpp"
#include "series/native.hpp"

#include <cstddef>
#include <vector>

namespace pgi {

/// Whether this processor runs the machine code attach_machine_code writes (x86-64 with AVX).
bool machine_code_supported();

/// The most terms and monomials a map written as machine code holds: a larger one stays interpreted (its code, about
/// 25 bytes a term, and its monomials, kept on the stack, would crowd the caches; native code's max_map_size). The
/// code takes 8 bytes of its caller's stack per monomial (at most 24 KiB), the interpreter none.
constexpr std::size_t machine_code_max_size = 3000;

/// Writes map's evaluator as machine code and attaches it (CompiledMap::attach_machine_code), unless the map runs
/// machine code already. Returns whether it runs machine code afterwards: false, the map left as it was, for a native
/// map (its code runs first), a map without outputs or of more than machine_code_max_size terms and monomials, on a
/// processor without AVX, or where the system refuses to make memory executable. Throws only std::bad_alloc (and
/// std::logic_error for a defect of the writer: its reads out of their planned order).
bool attach_machine_code(CompiledMap& map);
/// The same for each map that runs no native code; how many of maps run machine code afterwards.
std::size_t attach_machine_code(const std::vector<CompiledMap*>& maps);
/// The same as a scheme's jit policy gives it to the maps it builds beside its steps (its evaluators, a run's events
/// and dense output): every policy but never (which keeps the interpreter alone).
std::size_t attach_machine_code(const std::vector<CompiledMap*>& maps, NativePolicy policy);

}  // namespace pgi
