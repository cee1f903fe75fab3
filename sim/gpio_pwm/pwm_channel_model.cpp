#include "sim/gpio_pwm/pwm_channel_model.hpp"

#include <cerrno>

#include "drivers/gpio_pwm/sysfs_value.hpp"

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

std::string_view first_line(std::string_view text) {
  const std::size_t newline = text.find('\n');
  return newline == std::string_view::npos ? text : text.substr(0, newline);
}

}  // namespace

int PwmChannelModel::write(std::string_view name, std::string_view text) {
  PwmChannelState next = state_;
  if (name == "period" || name == "duty_cycle") {
    const auto value = parse_sysfs_u64(text);
    if (!value) return EINVAL;
    (name == "period" ? next.period_ns : next.duty_ns) = *value;
  } else if (name == "enable") {
    const auto value = parse_sysfs_u64(text);
    if (!value || *value > 1) return EINVAL;
    next.enabled = *value == 1;
  } else if (name == "polarity") {
    const std::string_view word = first_line(text);
    if (word == "normal") {
      next.inversed = false;
    } else if (word == "inversed") {
      next.inversed = true;
    } else {
      return EINVAL;
    }
    if (state_.enabled && next.inversed != state_.inversed) return EBUSY;
  } else {
    return ENOENT;
  }
  if (!acceptable(next)) return EINVAL;
  state_ = next;
  return 0;
}

std::string PwmChannelModel::read(std::string_view name) const {
  char text[32];
  return std::string(text, format(name, text, sizeof text));
}

std::size_t PwmChannelModel::format(std::string_view name, char* out, std::size_t size) const noexcept {
  if (size < 24) return 0;
  if (name == "period" || name == "duty_cycle") {
    return format_sysfs_u64(name == "period" ? state_.period_ns : state_.duty_ns, std::span<char>(out, size));
  }
  std::string_view text;
  if (name == "enable") text = state_.enabled ? "1\n" : "0\n";
  if (name == "polarity") text = state_.inversed ? "inversed\n" : "normal\n";
  text.copy(out, text.size());
  return text.size();
}

double PwmChannelModel::high_fraction() const noexcept {
  if (!state_.enabled || state_.period_ns == 0) return 0.0;
  const double duty = static_cast<double>(state_.duty_ns) / static_cast<double>(state_.period_ns);
  return state_.inversed ? 1.0 - duty : duty;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
