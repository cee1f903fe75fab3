#include "sim/gpio_pwm/pwm_channel_model.hpp"

#include <cerrno>

#include "sim/gpio_pwm/kernel_sysfs_text.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

// drivers/pwm/sysfs.c: period_store() and duty_cycle_store() take
// kstrtou64(buf, 0), enable_store() kstrtoint(buf, 0) and 0 or 1,
// polarity_store() sysfs_streq() with "normal" or "inversed".
int PwmChannelModel::write(std::string_view name, std::string_view text) {
  PwmChannelState next = state_;
  if (name == "period" || name == "duty_cycle") {
    std::uint64_t value = 0;
    if (const int error = kernel_kstrtoull(text, 0, value); error != 0) return error;
    (name == "period" ? next.period_ns : next.duty_ns) = value;
  } else if (name == "enable") {
    int value = 0;
    if (const int error = kernel_kstrtoint(text, 0, value); error != 0) return error;
    if (value != 0 && value != 1) return EINVAL;
    next.enabled = value == 1;
  } else if (name == "polarity") {
    if (kernel_sysfs_streq(text, "normal")) {
      next.inversed = false;
    } else if (kernel_sysfs_streq(text, "inversed")) {
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
    return kernel_print_llu(name == "period" ? state_.period_ns : state_.duty_ns, out, size);
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
