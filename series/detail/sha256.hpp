#pragma once
// SHA-256 (FIPS 180-4), self-contained: the native-code cache keeps each library's digest beside it and checks it
// before loading (series/native.cpp). No cryptographic library is linked by pgi, and this is all it needs of one.
#include <string>
#include <string_view>

namespace pgi::detail {

/// The SHA-256 digest of data as 64 lowercase hex digits.
std::string sha256_hex(std::string_view data);

}  // namespace pgi::detail
