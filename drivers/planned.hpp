#pragma once
/// \file
/// The drivers whose issues are still open, described with the parameters
/// they will take, so configs and docs can be written against them now. Each
/// driver issue replaces its entry with drivers/<kind>/'s own description.

#include "drivers/registry.hpp"

namespace hapticd::drivers::planned {

DriverDescription canopen_driver();

}  // namespace hapticd::drivers::planned
