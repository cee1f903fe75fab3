#include "drivers/simulation/plant_config.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "world/parameter.hpp"
#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::drivers::simulation {

namespace {

constexpr double linear_default_counts = 1.0 / 3.14e-6;  // LHifAM: 3.14 um per count

[[noreturn]] void fail(std::string_view key, const std::string& message) {
  throw ParameterError(std::string(key), "loopback: " + message);
}

namespace text = world::text;

/// Range bounds as in the scene catalog's messages: 1e-09, 1e+06.
std::string bound_text(double value) { return text::format_significant(value, text::precision::message); }

std::string number_text(double value) { return text::format_significant(value, text::precision::converted); }

}  // namespace

std::string_view to_string(PlantKind kind) noexcept {
  return kind == PlantKind::rigid ? "rigid" : "two-mass";
}

PlantConfig PlantConfig::defaults(Motion motion) {
  PlantConfig config;
  config.motion = motion;
  if (motion == Motion::linear) {
    config.mass = 0.1;
    config.damping = 0.0;
    config.counts = linear_default_counts;
    config.max_force = 10.0;
  }
  return config;
}

double PlantConfig::resolution() const noexcept {
  return motion == Motion::rotary ? 2.0 * world::units::pi / counts : 1.0 / counts;
}

double PlantConfig::total_mass() const noexcept {
  return plant == PlantKind::rigid ? mass : two_mass.total_mass();
}

double PlantConfig::total_damping() const noexcept {
  return plant == PlantKind::rigid ? damping : two_mass.total_damping();
}

void PlantConfig::validate() const {
  // Physically meaningful, generous ranges (world::parameter_range, as for
  // the scenes): a value outside is a typo, not a device.
  namespace r = world::parameter_range;
  auto within = [](std::string_view key, double value, double low, bool low_inclusive, double high) {
    const bool above = low_inclusive ? value >= low : value > low;
    if (!above || !(value <= high)) {
      fail(key, std::string(key) + " must be " + (low_inclusive ? ">= " : "> ") + bound_text(low) +
                    " and <= " + bound_text(high) + " (got " + number_text(value) + ")");
    }
  };
  auto mass_like = [&](std::string_view key, double value) {
    within(key, value, r::min_mass, true, r::max_mass);
  };
  auto damping_like = [&](std::string_view key, double value) {
    within(key, value, 0.0, true, r::max_damping);
  };
  if (plant == PlantKind::rigid) {
    mass_like("mass", mass);
    damping_like("damping", damping);
  } else {
    mass_like("motor_mass", two_mass.motor_mass);
    mass_like("body_mass", two_mass.body_mass);
    damping_like("motor_damping", two_mass.motor_damping);
    damping_like("body_damping", two_mass.body_damping);
    within("cable_stiffness", two_mass.cable_stiffness, 0.0, false, r::max_stiffness);
    damping_like("cable_damping", two_mass.cable_damping);
  }
  within("coulomb", coulomb, 0.0, true, r::max_force);
  within("counts", counts, 1.0, true, max_counts);
  within("max_force", max_force, 0.0, false, r::max_force);
  within("weight", weight, -r::max_force, true, r::max_force);
  within("period", period_s, min_period_s, true, max_period_s);
  if (delay < 0 || delay > max_delay_periods) {
    fail("delay", "delay must be an integer in 0.." + std::to_string(max_delay_periods) + " (got " +
                      std::to_string(delay) + ")");
  }
}

}  // namespace hapticd::drivers::simulation
