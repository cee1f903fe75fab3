#pragma once
/// \file
/// Where UDP telemetry goes: "host:port" with a numeric IPv4 address,
/// "[v6]:port", or "localhost:port" (127.0.0.1). No name lookup: the config
/// names the address it means, and a lookup would be a network dependency of
/// the daemon's start-up.

#include <sys/socket.h>

#include <optional>
#include <string>
#include <string_view>

namespace hapticd::daemon::telemetry {

struct UdpEndpoint {
  sockaddr_storage address{};
  socklen_t length = 0;
  std::string text;       ///< normalized: "127.0.0.1:9870", "[::1]:9870"
  bool loopback = false;  ///< 127.0.0.0/8, ::1 or ::ffff:127.0.0.0/104
  bool operator==(const UdpEndpoint& other) const { return text == other.text; }
};

/// The endpoint, or nullopt when `text` is not one (see endpoint_syntax()).
std::optional<UdpEndpoint> parse_endpoint(std::string_view text);
/// What parse_endpoint accepts, for error messages.
std::string_view endpoint_syntax() noexcept;

}  // namespace hapticd::daemon::telemetry
