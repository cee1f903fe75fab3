#include "sim/canopen/wire.hpp"

#include <linux/can.h>

#include <cstdio>

namespace hapticd::drivers::canopen::sim {

std::string to_text(Address address) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%04X:%02X", static_cast<unsigned>(address.index),
                static_cast<unsigned>(address.sub));
  return text;
}

bool is_data_frame(const Frame& frame) noexcept {
  return (frame.id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) == 0 && frame.id <= CAN_SFF_MASK &&
         frame.len <= CAN_MAX_DLEN;
}

std::uint32_t get_le(const Frame& frame, std::size_t offset, std::size_t bytes) noexcept {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < bytes && offset + i < frame.data.size(); ++i)
    value |= static_cast<std::uint32_t>(frame.data[offset + i]) << (8 * i);
  return value;
}

void put_le(Frame& frame, std::size_t offset, std::uint32_t value, std::size_t bytes) noexcept {
  for (std::size_t i = 0; i < bytes && offset + i < frame.data.size(); ++i)
    frame.data[offset + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

// ---- NMT ---------------------------------------------------------------------

std::optional<NmtRequest> parse_nmt(const Frame& frame) noexcept {
  if (!is_data_frame(frame) || frame.id != can_id(function_code::nmt, 0) || frame.len != 2)
    return std::nullopt;
  const std::uint8_t node = frame.data[1];
  if (node > 127) return std::nullopt;
  switch (frame.data[0]) {
    case 1:
    case 2:
    case 128:
    case 129:
    case 130:
      return NmtRequest{static_cast<NmtCommand>(frame.data[0]), node};
    default:
      return std::nullopt;
  }
}

std::string_view nmt_state_name(NmtState state) noexcept {
  switch (state) {
    case NmtState::boot_up:
      return "boot-up";
    case NmtState::stopped:
      return "stopped";
    case NmtState::operational:
      return "operational";
    case NmtState::pre_operational:
      return "pre-operational";
  }
  return "?";
}

Frame heartbeat(std::uint8_t node, NmtState state) noexcept {
  Frame f;
  f.id = can_id(function_code::nmt_error_control, node);
  f.len = 1;
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

std::optional<Heartbeat> parse_heartbeat(const Frame& frame) noexcept {
  if (!is_data_frame(frame) || frame.len != 1 || (frame.id >> 7) != function_code::nmt_error_control)
    return std::nullopt;
  const auto node = static_cast<std::uint8_t>(frame.id & 0x7FU);
  if (node == 0) return std::nullopt;
  const std::uint8_t state = frame.data[0] & 0x7FU;
  switch (state) {
    case 0:
    case 4:
    case 5:
    case 127:
      return Heartbeat{node, static_cast<NmtState>(state)};
    default:
      return std::nullopt;
  }
}

ConsumerEntry consumer_entry(std::uint32_t word) noexcept {
  return {word >> 24, static_cast<std::uint8_t>(word >> 16), static_cast<std::uint16_t>(word)};
}

// ---- SYNC and EMCY -------------------------------------------------------------

bool is_sync(const Frame& frame) noexcept {
  return is_data_frame(frame) && frame.id == can_id(function_code::sync, 0) && frame.len <= 1;
}

Frame emergency(std::uint8_t node, std::uint16_t error_code, std::uint8_t error_register) noexcept {
  Frame f;
  f.id = can_id(function_code::emcy, node);
  f.len = 8;
  put_le(f, 0, error_code, 2);
  f.data[2] = error_register;
  return f;
}

// ---- PDO parameters ------------------------------------------------------------

PdoCobId pdo_cob_id(std::uint32_t word) noexcept {
  PdoCobId c;
  c.valid = (word >> 31 & 1U) == 0;
  c.rtr_allowed = (word >> 30 & 1U) == 0;
  c.extended = (word >> 29 & 1U) != 0;
  c.upper_bits = word >> 11 & 0x3FFFFU;
  c.can_id = word & 0x7FFU;
  return c;
}

std::uint32_t pdo_cob_id_word(std::uint32_t can_id, bool valid) noexcept {
  return (valid ? 0U : 1U << 31) | 1U << 30 | (can_id & 0x7FFU);
}

bool restricted_can_id(std::uint32_t id) noexcept {
  struct Range {
    std::uint32_t first, last;
  };
  static constexpr Range restricted[] = {{0x000, 0x07F}, {0x101, 0x180}, {0x581, 0x5FF},
                                         {0x601, 0x67F}, {0x6E0, 0x6FF}, {0x701, 0x7FF}};
  for (const Range& r : restricted)
    if (id >= r.first && id <= r.last) return true;
  return false;
}

MappedObject mapped_object(std::uint32_t word) noexcept {
  return {static_cast<std::uint16_t>(word >> 16), static_cast<std::uint8_t>(word >> 8),
          static_cast<std::uint8_t>(word)};
}

std::uint32_t mapping_word(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) noexcept {
  return static_cast<std::uint32_t>(index) << 16 | static_cast<std::uint32_t>(sub) << 8 | bits;
}

}  // namespace hapticd::drivers::canopen::sim
