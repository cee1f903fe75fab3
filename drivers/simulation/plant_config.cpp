#include "drivers/simulation/plant_config.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "world/units.hpp"

namespace hapticd::drivers::simulation {

namespace {

constexpr double linear_default_counts = 1.0 / 3.14e-6;  // LHifAM: 3.14 um per count

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument("loopback: " + message); }

std::string number_text(double value) {
  std::ostringstream out;
  out.precision(12);
  out << value;
  return out.str();
}

}  // namespace

std::string_view to_string(PlantKind kind) noexcept {
  return kind == PlantKind::rigid ? "rigid" : "two-mass";
}

PlantConfig PlantConfig::defaults(Motion motion) {
  PlantConfig config;
  config.motion = motion;
  if (motion == Motion::linear) {
    config.mass = 0.1;
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
  auto positive = [](std::string_view key, double value) {
    if (!(value > 0.0) || !std::isfinite(value))
      fail(std::string(key) + " must be > 0 (got " + number_text(value) + ")");
  };
  auto non_negative = [](std::string_view key, double value) {
    if (!(value >= 0.0) || !std::isfinite(value))
      fail(std::string(key) + " must be >= 0 (got " + number_text(value) + ")");
  };
  if (plant == PlantKind::rigid) {
    positive("mass", mass);
    non_negative("damping", damping);
  } else {
    positive("motor_mass", two_mass.motor_mass);
    positive("body_mass", two_mass.body_mass);
    non_negative("motor_damping", two_mass.motor_damping);
    non_negative("body_damping", two_mass.body_damping);
    positive("cable_stiffness", two_mass.cable_stiffness);
    non_negative("cable_damping", two_mass.cable_damping);
  }
  non_negative("coulomb", coulomb);
  positive("counts", counts);
  positive("max_force", max_force);
  positive("period", period_s);
  if (delay < 0 || delay > max_delay_periods) {
    fail("delay must be an integer in 0.." + std::to_string(max_delay_periods) + " (got " +
         std::to_string(delay) + ")");
  }
}

}  // namespace hapticd::drivers::simulation
