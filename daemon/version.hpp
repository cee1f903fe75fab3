#pragma once
/// \file
/// hapticd's version, from the CMake project version.

#include <string_view>

namespace hapticd {
#ifndef HAPTICD_VERSION
#define HAPTICD_VERSION "0.1.0"
#endif
inline constexpr std::string_view version = HAPTICD_VERSION;
}  // namespace hapticd
