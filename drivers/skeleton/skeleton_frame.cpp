#include "drivers/skeleton/skeleton_frame.hpp"

namespace hapticd::drivers::skeleton {

namespace {

// Request flags (byte 2) and reply status (byte 2): README.md's table.
constexpr std::uint8_t flag_enable = 0x01, flag_reset = 0x02;
constexpr std::uint8_t status_enabled = 0x01, status_faulted = 0x02, status_reserved = 0xFC;

void put_u16(Frame& f, std::size_t at, std::uint16_t v) noexcept {
  f[at] = static_cast<std::uint8_t>(v & 0xFF);
  f[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put_i32(Frame& f, std::size_t at, std::int32_t v) noexcept {
  const auto u = static_cast<std::uint32_t>(v);
  for (std::size_t i = 0; i < 4; ++i) f[at + i] = static_cast<std::uint8_t>(u >> (8 * i));
}
std::uint16_t get_u16(std::span<const std::uint8_t> b, std::size_t at) noexcept {
  return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8));
}
std::int32_t get_i32(std::span<const std::uint8_t> b, std::size_t at) noexcept {
  std::uint32_t u = 0;
  for (std::size_t i = 0; i < 4; ++i) u |= static_cast<std::uint32_t>(b[at + i]) << (8 * i);
  return static_cast<std::int32_t>(u);
}

}  // namespace

Frame encode(const Request& request) noexcept {
  Frame f{};
  put_u16(f, 0, request.sequence);
  f[2] = static_cast<std::uint8_t>((request.enable ? flag_enable : 0) | (request.reset ? flag_reset : 0));
  f[3] = 0;  // reserved
  put_i32(f, 4, request.command);
  return f;
}

std::optional<Reply> decode_reply(std::span<const std::uint8_t> bytes) noexcept {
  if (bytes.size() != frame_size || (bytes[2] & status_reserved) != 0) return std::nullopt;
  Reply r;
  r.sequence = get_u16(bytes, 0);
  r.enabled = (bytes[2] & status_enabled) != 0;
  r.faulted = (bytes[2] & status_faulted) != 0;
  r.fault_code = bytes[3];
  r.position = get_i32(bytes, 4);
  return r;
}

}  // namespace hapticd::drivers::skeleton
