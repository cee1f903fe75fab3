#pragma once
/// \file
/// A failure of the GPIO chip, a line, or a sysfs attribute at configure
/// time: one line with the path, the value and the system's reason, and the
/// configuration key to blame (a DeviceError, which the daemon places at
/// that key's file:line:column), plus the errno.

#include <string>
#include <system_error>

#include "drivers/device_hooks.hpp"

namespace hapticd::drivers::gpio_pwm {

/// The system's words for an errno (thread-safe, unlike strerror).
inline std::string system_reason(int error) {
  return std::error_code(error, std::generic_category()).message();
}

class TransportError : public DeviceError {
 public:
  TransportError(std::string key, const std::string& message, int error_code = 0)
      : DeviceError(message, std::move(key)), error_code_(error_code) {}
  int error_code() const noexcept { return error_code_; }

 private:
  int error_code_;
};

}  // namespace hapticd::drivers::gpio_pwm
