#pragma once
// NPY files (numpy's format, version 1.0 written; 1.0, 2.0 and 3.0 read): float64, C order, 2-D only. The
// format is magic "\x93NUMPY", two version bytes, the header's length (2 bytes in 1.0, 4 in 2.0 and 3.0,
// little-endian), a Python dict literal {'descr': '<f8', 'fortran_order': False, 'shape': (m, n), } padded
// with spaces to a multiple of 64 bytes and ended by '\n', then the m n doubles, row after row.
// Also the CSV form of the same matrices (one row per line).
#include "scheme/ensemble.hpp"

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

namespace pgi {

/// A 2-D float64 C-order array. Throws InputError (key: the file) for anything else: a missing file, a bad
/// magic or version, a header that is not the dict above, another dtype, Fortran order, a shape that is not
/// (m, n), or a data length that is not m n 8 bytes exactly; and what read_input_file refuses (not a regular
/// file, above max_bytes).
RowMatrix read_npy(const std::filesystem::path& file, std::size_t max_bytes);
/// read_npy's parser on the file's bytes (file names it in messages).
RowMatrix parse_npy(const std::string& bytes, const std::string& file);
void write_npy(std::ostream& out, const Eigen::Ref<const RowMatrix>& a);

/// Rows of `columns` numbers separated by commas; blank lines and lines starting with '#' are skipped, and
/// a first line equal to header (the coordinates' names joined by commas) too. nan and inf are read as
/// such. Throws InputError naming the file and line for a row of another length or a field not a number (its
/// first 40 characters shown), and what read_input_file refuses (not a regular file, above max_bytes).
RowMatrix read_csv_states(const std::filesystem::path& file, std::size_t columns, const std::string& header,
                          std::size_t max_bytes);
/// read_csv_states' parser on the file's text (file names it in messages).
RowMatrix parse_csv_states(const std::string& text, const std::string& file, std::size_t columns,
                           const std::string& header);

}  // namespace pgi
