#include "daemon/telemetry/udp_endpoint.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <charconv>
#include <cstring>

namespace hapticd::daemon::telemetry {

namespace {

std::optional<std::uint16_t> parse_port(std::string_view text) {
  unsigned value = 0;
  const auto* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc{} || ptr != end || value == 0 || value > 65535) return std::nullopt;
  return static_cast<std::uint16_t>(value);
}

}  // namespace

std::string_view endpoint_syntax() noexcept {
  return "\"ADDRESS:PORT\" with a numeric IPv4 address (\"127.0.0.1:9870\"), \"[IPv6]:PORT\" "
         "(\"[::1]:9870\") or \"localhost:PORT\"; PORT 1 to 65535";
}

std::optional<UdpEndpoint> parse_endpoint(std::string_view text) {
  std::string host;
  std::string_view port_text;
  bool v6 = false;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string_view::npos || close + 1 >= text.size() || text[close + 1] != ':')
      return std::nullopt;
    host = std::string(text.substr(1, close - 1));
    port_text = text.substr(close + 2);
    v6 = true;
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos || text.find(':') != colon) return std::nullopt;
    host = std::string(text.substr(0, colon));
    port_text = text.substr(colon + 1);
  }
  const auto port = parse_port(port_text);
  if (!port) return std::nullopt;
  if (host == "localhost" && !v6) host = "127.0.0.1";

  UdpEndpoint out;
  char normalized[INET6_ADDRSTRLEN] = {};
  if (v6) {
    sockaddr_in6 a{};
    a.sin6_family = AF_INET6;
    a.sin6_port = htons(*port);
    if (::inet_pton(AF_INET6, host.c_str(), &a.sin6_addr) != 1) return std::nullopt;
    ::inet_ntop(AF_INET6, &a.sin6_addr, normalized, sizeof normalized);
    const bool mapped_loopback = IN6_IS_ADDR_V4MAPPED(&a.sin6_addr) && a.sin6_addr.s6_addr[12] == 127;
    out.loopback = IN6_IS_ADDR_LOOPBACK(&a.sin6_addr) || mapped_loopback;
    std::memcpy(&out.address, &a, sizeof a);
    out.length = sizeof a;
    out.text = "[" + std::string(normalized) + "]:" + std::to_string(*port);
  } else {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(*port);
    if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) return std::nullopt;
    ::inet_ntop(AF_INET, &a.sin_addr, normalized, sizeof normalized);
    out.loopback = (ntohl(a.sin_addr.s_addr) >> 24) == 127;
    std::memcpy(&out.address, &a, sizeof a);
    out.length = sizeof a;
    out.text = std::string(normalized) + ":" + std::to_string(*port);
  }
  return out;
}

}  // namespace hapticd::daemon::telemetry
