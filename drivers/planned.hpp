#pragma once
/// \file
/// Drivers whose issues are still open, described with the parameters they
/// will take, so configs and docs can be written against them before the
/// code. Each driver issue replaces its entry with drivers/<kind>/'s own
/// description.

#include <string>
#include <vector>

#include "drivers/driver_description.hpp"

namespace hapticd::drivers::planned {

/// A planned driver's description (not ready: a config naming it is refused
/// in one line): the parameters every device takes (motion, mass, damping)
/// and `specific`. No driver is planned now; a new one adds its entry to the
/// registry with this.
DriverDescription planned(std::string name, std::string summary, std::vector<ParameterSpec> specific);

}  // namespace hapticd::drivers::planned
