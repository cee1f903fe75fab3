#include "drivers/gpio_pwm/gpio_pwm_config.hpp"

#include <array>
#include <cmath>
#include <numbers>
#include <utility>

#include "drivers/gpio_pwm/gpio_pwm_device.hpp"
#include "world/parameter.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::gpio_pwm {
namespace {

constexpr std::size_t max_name_length = 31;  // uAPI: char name[32], NUL-terminated

using world::text::format_number;

void require(bool ok, const char* key, const std::string& message) {
  if (!ok) throw ParameterError(key, message);
}

void require_finite_range(double value, const char* key, double low, double high, bool low_open,
                          const char* unit) {
  const bool above = low_open ? value > low : value >= low;
  require(std::isfinite(value) && above && value <= high, key,
          std::string(key) + " = " + format_number(value) + " is out of range; accepted: " +
              (low_open ? "above " : "") + format_number(low) + (low_open ? " up to " : " to ") +
              format_number(high) + (unit[0] != '\0' ? std::string(" ") + unit : std::string()));
}

void check_required_line(const LineSpec& line, const char* key, const char* what) {
  require(
      line.configured(), key,
      std::string(key) + " is required (" + what + "); accepted: a line offset on the chip or a line name");
}

void check_distinct_lines(const GpioPwmConfig& c) {
  const std::array<std::pair<const char*, const LineSpec*>, 8> lines{{
      {"enable_line", &c.enable_line},
      {"direction_line", &c.direction_line},
      {"fault_line", &c.fault_line},
      {"brake_line", &c.brake_line},
      {"reset_line", &c.reset_line},
      {"charge_pump_line", &c.charge_pump_line},
      {"encoder_a_line", &c.encoder_a_line},
      {"encoder_b_line", &c.encoder_b_line},
  }};
  for (std::size_t i = 0; i < lines.size(); ++i) {
    for (std::size_t j = i + 1; j < lines.size(); ++j) {
      const LineSpec& a = *lines[i].second;
      const LineSpec& b = *lines[j].second;
      if (!a.configured() || !b.configured()) continue;
      const bool same =
          (a.offset && b.offset && *a.offset == *b.offset) || (!a.name.empty() && a.name == b.name);
      require(!same, lines[j].first,
              std::string(lines[j].first) + " = " + b.describe() + " is already " + lines[i].first +
                  "; every line has one role");
    }
  }
}

}  // namespace

std::string LineSpec::describe() const {
  if (offset) return std::to_string(*offset);
  if (!name.empty()) return "\"" + name + "\"";
  return "none";
}

LineSpec parse_line_spec(std::string_view key, std::string_view text, bool active_low) {
  LineSpec spec;
  spec.active_low = active_low;
  if (text.empty()) return spec;
  const bool all_digits = text.find_first_not_of("0123456789") == std::string_view::npos;
  if (all_digits) {
    if (text.size() > 6) {
      throw ParameterError(std::string(key),
                           std::string(key) + " = " + std::string(text) +
                               " is not a line offset; accepted: 0 to 65535 or a line name");
    }
    const unsigned long value = std::stoul(std::string(text));
    if (value > 65535) {
      throw ParameterError(std::string(key),
                           std::string(key) + " = " + std::string(text) +
                               " is not a line offset; accepted: 0 to 65535 or a line name");
    }
    spec.offset = static_cast<unsigned>(value);
    return spec;
  }
  if (text.size() > max_name_length) {
    throw ParameterError(std::string(key),
                         std::string(key) + " = \"" + std::string(text) +
                             "\" is longer than a GPIO line name can be; accepted: up to 31 characters");
  }
  spec.name = std::string(text);
  return spec;
}

double GpioPwmConfig::metres_or_radians_per_count() const noexcept {
  return motion == Motion::rotary ? 2.0 * std::numbers::pi / counts_per_unit : 1.0 / counts_per_unit;
}

void validate(const GpioPwmConfig& c) {
  require(!c.chip.empty(), "chip",
          "chip is empty; accepted: a GPIO chip path (/dev/gpiochip0), name (gpiochip0), number or label");
  require(!c.consumer.empty() && c.consumer.size() <= max_name_length, "consumer",
          "consumer = \"" + c.consumer + "\" is not accepted; accepted: 1 to 31 characters");
  check_required_line(c.enable_line, "enable_line", "the amplifier enable output");
  check_required_line(c.direction_line, "direction_line", "the H-bridge direction output");
  require(
      !c.pwm_chip.empty() && c.pwm_chip.front() == '/', "pwm_chip",
      "pwm_chip = \"" + c.pwm_chip + "\" is not an absolute path; accepted: e.g. /sys/class/pwm/pwmchip0");
  require(c.pwm_period_ns >= 1'000 && c.pwm_period_ns <= 1'000'000'000, "pwm_period",
          "pwm_period = " + std::to_string(c.pwm_period_ns) + " ns is out of range; accepted: 1 us to 1 s");
  require_finite_range(c.force_at_full_duty, "force_at_full_duty", 0.0, 1e6, true, "N or N m");
  require_finite_range(c.max_duty, "max_duty", 0.0, 1.0, true, "");
  require_finite_range(c.deadband, "deadband", 0.0, 1e6, false, "N or N m");
  require(c.deadband < c.force_at_full_duty * c.max_duty, "deadband",
          "deadband = " + format_number(c.deadband) +
              " is not below the largest force (force_at_full_duty x max_duty = " +
              format_number(c.force_at_full_duty * c.max_duty) + "): every command would give duty 0");
  require_finite_range(c.counts_per_unit, "counts_per_unit", 0.0, 1e12, true,
                       "counts per revolution or metre");
  require(c.mass > 0.0, "mass",
          "mass is required (" +
              std::string(c.motion == Motion::rotary ? "kg m^2: the moving inertia" : "kg: the moving mass") +
              ", for the stability gate)");
  require_finite_range(c.mass, "mass", world::parameter_range::min_mass, world::parameter_range::max_mass,
                       false, c.motion == Motion::rotary ? "kg m^2" : "kg");
  require_finite_range(c.damping, "damping", 0.0, world::parameter_range::max_damping, false,
                       c.motion == Motion::rotary ? "N m s/rad" : "N s/m");
  require_finite_range(c.reset_pulse_s, "reset_pulse", 1e-6, 1.0, false, "s");
  require_finite_range(c.export_timeout_s, "export_timeout", 0.0, 10.0, true, "s");
  if (c.position_source() == PositionSource::counter) {
    require(c.counter.front() == '/', "counter",
            "counter = \"" + c.counter +
                "\" is not an absolute path; accepted: a counter's sysfs directory, e.g. "
                "/sys/bus/counter/devices/counter0, or \"\" for quadrature lines");
    const char* encoder_key = c.encoder_a_line.configured() ? "encoder_a_line" : "encoder_b_line";
    require(!c.encoder_a_line.configured() && !c.encoder_b_line.configured(), encoder_key,
            std::string(encoder_key) +
                " and counter are both set; accepted: one position source (counter = \"\" "
                "to decode the encoder lines, or no encoder lines with a counter)");
  } else {
    check_required_line(c.encoder_a_line, "encoder_a_line", "quadrature input A, since no counter is named");
    check_required_line(c.encoder_b_line, "encoder_b_line", "quadrature input B, since no counter is named");
  }
  check_distinct_lines(c);
}

}  // namespace hapticd::drivers::gpio_pwm

namespace hapticd::drivers::gpio_pwm {

GpioPwmConfig gpio_pwm_config_from(const DriverParameters& p) {
  GpioPwmConfig c;
  c.motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.chip = p.text("chip");
  c.consumer = p.text("consumer");
  const auto line_of = [&p](const char* key, const char* low_key) {
    return parse_line_spec(key, p.text(key), low_key != nullptr && p.boolean(low_key));
  };
  c.enable_line = line_of("enable_line", "enable_active_low");
  c.direction_line = line_of("direction_line", "direction_active_low");
  c.fault_line = line_of("fault_line", "fault_active_low");
  c.brake_line = line_of("brake_line", "brake_active_low");
  c.reset_line = line_of("reset_line", "reset_active_low");
  c.charge_pump_line = line_of("charge_pump_line", nullptr);
  c.encoder_a_line = line_of("encoder_a_line", "encoder_a_active_low");
  c.encoder_b_line = line_of("encoder_b_line", "encoder_b_active_low");
  c.pwm_chip = p.text("pwm_chip");
  c.pwm_channel = static_cast<unsigned>(p.integer("pwm_channel"));
  c.pwm_period_ns = static_cast<std::uint64_t>(std::llround(p.duration_s("pwm_period") * 1e9));
  c.pwm_inversed = p.boolean("pwm_inversed");
  c.force_at_full_duty = p.number("force_at_full_duty");
  c.max_duty = p.number("max_duty");
  c.deadband = p.number("deadband");
  c.counter = p.text("counter");
  c.counter_count = static_cast<unsigned>(p.integer("counter_count"));
  c.counts_per_unit = p.number("counts_per_unit");
  c.reverse = p.boolean("reverse");
  c.reset_pulse_s = p.duration_s("reset_pulse");
  c.export_timeout_s = p.duration_s("export_timeout");
  validate(c);
  return c;
}

}  // namespace hapticd::drivers::gpio_pwm
