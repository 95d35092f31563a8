#pragma once
// pgi's version, as CMake's project(VERSION) gives it ("0.1.0").
#include <string_view>

namespace pgi {

std::string_view version();

}  // namespace pgi
