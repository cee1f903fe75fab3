#include "drivers/loopback/loopback_config.hpp"

#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "drivers/loopback/key_value.hpp"
#include "drivers/loopback/parameter_error.hpp"
#include "world/scene_catalog.hpp"
#include "world/units.hpp"

namespace hapticd::drivers::loopback {

namespace {

constexpr double linear_default_counts = 1.0 / 3.14e-6;  // LHifAM: 3.14 um per count

[[noreturn]] void fail(std::string_view key, const std::string& message) {
  throw ParameterError(std::string(key), "loopback: " + message);
}

std::string number_text(double value) {
  std::ostringstream out;
  out.precision(12);
  out << value;
  return out.str();
}

/// Range bounds as in the scene catalog's messages: 1e-09, 1e+06.
std::string bound_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double parse_number(std::string_view key, std::string_view value) {
  const auto parsed = world::units::parse_finite(value);
  if (!parsed) fail(key, std::string(key) + "=" + std::string(value) + " is not a finite number");
  return *parsed;
}

}  // namespace

std::string_view to_string(PlantKind kind) noexcept {
  return kind == PlantKind::rigid ? "rigid" : "two-mass";
}
std::string_view to_string(Motion motion) noexcept { return motion == Motion::rotary ? "rotary" : "linear"; }

LoopbackConfig LoopbackConfig::defaults(Motion motion) {
  LoopbackConfig config;
  config.motion = motion;
  if (motion == Motion::linear) {
    config.mass = 0.1;
    config.damping = 0.0;
    config.counts = linear_default_counts;
    config.max_force = 10.0;
  }
  return config;
}

double LoopbackConfig::resolution() const noexcept {
  return motion == Motion::rotary ? 2.0 * world::units::pi / counts : 1.0 / counts;
}

double LoopbackConfig::total_mass() const noexcept {
  return plant == PlantKind::rigid ? mass : two_mass.total_mass();
}

double LoopbackConfig::total_damping() const noexcept {
  return plant == PlantKind::rigid ? damping : two_mass.total_damping();
}

void LoopbackConfig::validate() const {
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
  within("period", period_s, min_period_s, true, max_period_s);
  if (delay < 0 || delay > max_delay_periods) {
    fail("delay", "delay must be an integer in 0.." + std::to_string(max_delay_periods) + " (got " +
                      std::to_string(delay) + ")");
  }
}

std::vector<DriverParameter> loopback_parameters() {
  namespace r = world::parameter_range;
  const LoopbackConfig rotary = LoopbackConfig::defaults(Motion::rotary);
  const LoopbackConfig linear = LoopbackConfig::defaults(Motion::linear);
  const world::TwoMassPlant tm{};
  const std::string masses = "; " + bound_text(r::min_mass) + " to " + bound_text(r::max_mass);
  const std::string dampings = "; 0 to " + bound_text(r::max_damping);
  return {
      {"motion", "string", "rotary", "",
       "rotary (wheel: rad, N m, kg m^2) or linear (m, N, kg); selects the defaults below"},
      {"plant", "string", "rigid", "",
       "rigid (one mass) or two-mass (motor and body joined by a cable, Diaz & Gil eq. 3-9)"},
      {"mass", "number", number_text(rotary.mass), "kg m^2 | kg",
       "rigid plant: moving inertia (rotary default " + number_text(rotary.mass) +
           " kg m^2) or mass (linear default " + number_text(linear.mass) + " kg)" + masses},
      {"damping", "number", number_text(rotary.damping), "N m s/rad | N s/m",
       "rigid plant: viscous damping to ground (rotary default " + number_text(rotary.damping) +
           " N m s/rad of bearing friction, linear default " + number_text(linear.damping) + " N s/m)" +
           dampings},
      {"coulomb", "number", "0", "N m | N",
       "Coulomb friction level with stiction (rigid: on the mass; two-mass: on the body); 0 disables; 0 to " +
           bound_text(r::max_force)},
      {"motor_mass", "number", number_text(tm.motor_mass), "kg",
       "two-mass: motor-side mass m_m (Table I)" + masses},
      {"body_mass", "number", number_text(tm.body_mass), "kg",
       "two-mass: body (handle) mass m_d (Table I)" + masses},
      {"motor_damping", "number", number_text(tm.motor_damping), "N s/m",
       "two-mass: motor damping b_m (Table I)" + dampings},
      {"body_damping", "number", number_text(tm.body_damping), "N s/m",
       "two-mass: body damping b_d (Table I)" + dampings},
      {"cable_stiffness", "number", number_text(tm.cable_stiffness), "N/m",
       "two-mass: cable stiffness k_c (Table I); > 0 to " + bound_text(r::max_stiffness)},
      {"cable_damping", "number", number_text(tm.cable_damping), "N s/m",
       "two-mass: cable damping b_c (Table I)" + dampings},
      {"sensor", "string", "motor", "",
       "two-mass: position read() returns: motor (collocated) or body (non-collocated)"},
      {"counts", "number", number_text(rotary.counts), "1/rev | 1/m",
       "encoder counts per revolution (rotary, default 4096*4) or per metre (linear, default " +
           number_text(linear.counts) + " = 1/3.14 um); 1 to " + bound_text(max_counts)},
      {"max_force", "number", number_text(rotary.max_force), "N m | N",
       "actuator saturation |force| (rotary default " + number_text(rotary.max_force) +
           " N m, linear default " + number_text(linear.max_force) + " N); > 0 to " +
           bound_text(r::max_force)},
      {"delay", "integer", "0", "periods",
       "extra output delay: a force written in period n is applied in period n+delay (0.." +
           std::to_string(max_delay_periods) + ")"},
      {"period", "number", "0.001", "s",
       "simulation period T (accepts 1ms, 250us); time = writes * T; 1us to 1s"},
  };
}

LoopbackConfig parse_loopback_config(const std::vector<std::pair<std::string, std::string>>& pairs) {
  Motion motion = Motion::rotary;
  for (const auto& [key, value] : pairs) {
    if (key != "motion") continue;
    if (value == "rotary") {
      motion = Motion::rotary;
    } else if (value == "linear") {
      motion = Motion::linear;
    } else {
      fail(key, "motion=" + value + " is not one of rotary, linear");
    }
  }
  LoopbackConfig config = LoopbackConfig::defaults(motion);
  for (const auto& [key, value] : pairs) {
    if (key == "motion") continue;
    if (key == "plant") {
      if (value == "rigid") {
        config.plant = PlantKind::rigid;
      } else if (value == "two-mass" || value == "two_mass") {
        config.plant = PlantKind::two_mass;
      } else {
        fail(key, "plant=" + value + " is not one of rigid, two-mass");
      }
    } else if (key == "mass") {
      config.mass = parse_number(key, value);
    } else if (key == "damping") {
      config.damping = parse_number(key, value);
    } else if (key == "coulomb") {
      config.coulomb = parse_number(key, value);
    } else if (key == "motor_mass") {
      config.two_mass.motor_mass = parse_number(key, value);
    } else if (key == "body_mass") {
      config.two_mass.body_mass = parse_number(key, value);
    } else if (key == "motor_damping") {
      config.two_mass.motor_damping = parse_number(key, value);
    } else if (key == "body_damping") {
      config.two_mass.body_damping = parse_number(key, value);
    } else if (key == "cable_stiffness") {
      config.two_mass.cable_stiffness = parse_number(key, value);
    } else if (key == "cable_damping") {
      config.two_mass.cable_damping = parse_number(key, value);
    } else if (key == "sensor") {
      const auto sensor = world::parse_sensor(value);
      if (!sensor) fail(key, "sensor=" + value + " is not one of motor, body");
      config.sensor = *sensor;
    } else if (key == "counts") {
      config.counts = parse_number(key, value);
    } else if (key == "max_force") {
      config.max_force = parse_number(key, value);
    } else if (key == "delay") {
      int delay = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), delay);
      if (ec != std::errc{} || end != value.data() + value.size()) {
        fail(key, "delay=" + value + " is not an integer number of periods");
      }
      config.delay = delay;
    } else if (key == "period") {
      const auto period = world::units::parse_duration_s(value);
      if (!period) fail(key, "period=" + value + " is not a duration (e.g. 0.001, 1ms, 250us)");
      config.period_s = *period;
    } else {
      std::string accepted;
      for (const auto& parameter : loopback_parameters()) {
        if (!accepted.empty()) accepted += ", ";
        accepted += parameter.name;
      }
      fail(key, "unknown key '" + key + "'; accepted: " + accepted);
    }
  }
  config.validate();
  return config;
}

LoopbackConfig parse_loopback_config(std::string_view text) {
  return parse_loopback_config(detail::split_key_values(text, "loopback"));
}

}  // namespace hapticd::drivers::loopback
