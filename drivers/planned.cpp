#include "drivers/planned.hpp"

namespace hapticd::drivers::planned {

namespace {

using P = ParameterSpec;

/// What every real device needs for the stability gate (DRIVERS.md): the
/// device cannot know its own moving mass, so the config says it.
std::vector<ParameterSpec> common() {
  return {P::choice("motion", {"rotary", "linear"},
                    "rotary (rad, N m, kg m^2) or linear (m, N, kg): the units of everything below")
              .defaults_to("rotary"),
          P::number("mass", "kg m^2 | kg", "moving inertia (rotary) or mass (linear) the stability gate uses")
              .above(0.0)
              .at_most(1e6),
          P::number("damping", "N m s/rad | N s/m", "viscous damping to ground the stability gate uses")
              .defaults_to(0.0)
              .at_least(0.0)
              .at_most(1e6)};
}

}  // namespace

DriverDescription planned(std::string name, std::string summary, std::vector<ParameterSpec> specific) {
  std::vector<ParameterSpec> all = common();
  for (auto& p : specific) all.push_back(std::move(p));
  return {std::move(name), std::move(summary), false, std::move(all), {}};
}

}  // namespace hapticd::drivers::planned
