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

DriverDescription planned(std::string name, std::string summary, std::vector<ParameterSpec> specific) {
  std::vector<ParameterSpec> all = common();
  for (auto& p : specific) all.push_back(std::move(p));
  return {std::move(name), std::move(summary), false, std::move(all), {}};
}

P counts_per_unit() {
  return P::number("counts_per_unit", "1/rev | 1/m", "encoder counts per revolution or per metre").above(0.0);
}

}  // namespace

DriverDescription canopen_driver() {
  return planned(
      "canopen", "CiA 402 drive over SocketCAN, cyclic synchronous torque (CiA 301/402)",
      {P::text("interface", "SocketCAN interface, or unix:/path for the simulated bus").defaults_to("can0"),
       P::integer("node_id", "", "CANopen node id").defaults_to(1.0).at_least(1).at_most(127),
       P::number("bitrate", "bit/s", "bus bitrate, for the bus budget")
           .defaults_to(1e6)
           .at_least(10e3)
           .at_most(1e6),
       counts_per_unit(),
       P::number("rated_torque", "N m | N", "rated torque 0x6076 in SI (0x6071 is per mille of it)")
           .above(0.0)});
}

}  // namespace hapticd::drivers::planned
