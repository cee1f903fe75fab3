#include "drivers/planned.hpp"

namespace hapticd::drivers::planned {

namespace {

using P = ParameterSpec;

/// What every real device needs for the stability gate (DRIVERS.md): the
/// device cannot know its own moving mass, so the config says it.
std::vector<ParameterSpec> common() { return {motion_parameter(), mass_parameter(), damping_parameter()}; }

}  // namespace

DriverDescription planned(std::string name, std::string summary, std::vector<ParameterSpec> specific) {
  std::vector<ParameterSpec> all = common();
  for (auto& p : specific) all.push_back(std::move(p));
  return {std::move(name), std::move(summary), false, std::move(all), {}};
}

}  // namespace hapticd::drivers::planned
