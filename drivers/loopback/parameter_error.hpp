#pragma once
/// \file
/// The error a loopback key (device parameter or hand-script key) is refused
/// with. It names the key structurally, so whoever holds the key's source
/// position (the daemon's config, the CLI) can point at it without reading
/// the message.

#include <stdexcept>
#include <string>
#include <utility>

namespace hapticd::drivers::loopback {

class ParameterError : public std::invalid_argument {
 public:
  /// key: the key as written ("damping", "amplitude"); empty when the text
  /// is malformed and no key can be named.
  ParameterError(std::string key, const std::string& message)
      : std::invalid_argument(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

}  // namespace hapticd::drivers::loopback
