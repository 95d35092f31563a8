#pragma once
// The one rule for text that reaches a message (stderr, an exception's what()): control characters shown as \xNN,
// the length bounded; used for the CLI's messages and for what child processes (the compiler, gnuplot) print.
#include <cstddef>
#include <string>
#include <string_view>

namespace pgi {

/// s with every control character (NUL, ESC, newline, ... and DEL) written as \xNN, so a message never carries raw
/// terminal codes and is never cut by a NUL.
std::string printable(std::string_view s);

/// The last `lines` non-empty lines of a program's output joined by " | ", each printable, the whole at most
/// max_chars (the start cut off and marked "..."): a child's diagnostics as one bounded line.
std::string output_tail(std::string_view output, std::size_t lines = 8, std::size_t max_chars = 1500);

}  // namespace pgi
