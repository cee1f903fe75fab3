#pragma once
/// \file
/// A failure of the GPIO chip, a line, or a sysfs attribute at configure
/// time: one line with the path, the value and the system's reason, and the
/// configuration key to blame.

#include <stdexcept>
#include <string>
#include <system_error>

namespace hapticd::drivers::gpio_pwm {

/// The system's words for an errno (thread-safe, unlike strerror).
inline std::string system_reason(int error) {
  return std::error_code(error, std::generic_category()).message();
}

class TransportError : public std::runtime_error {
 public:
  TransportError(std::string key, const std::string& message, int error_code = 0)
      : std::runtime_error(message), key_(std::move(key)), error_code_(error_code) {}
  const std::string& key() const noexcept { return key_; }
  int error_code() const noexcept { return error_code_; }

 private:
  std::string key_;
  int error_code_;
};

}  // namespace hapticd::drivers::gpio_pwm
