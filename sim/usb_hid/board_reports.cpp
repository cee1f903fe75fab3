#include "sim/usb_hid/board_reports.hpp"

#include <algorithm>
#include <cstring>

namespace hapticd::drivers::usb_hid::sim {

namespace {

std::uint16_t u16le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (static_cast<unsigned>(p[1]) << 8U));
}

void put_u16le(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v & 0xFFU);
  p[1] = static_cast<std::uint8_t>(v >> 8U);
}

}  // namespace

bool read_out_report(std::span<const std::uint8_t> bytes, BoardCommand& out, std::size_t axes) noexcept {
  if (axes < 1 || axes > max_board_axes || bytes.size() < out_report_bytes_for(axes)) return false;
  const std::uint8_t* r = bytes.data();
  out.sequence = u16le(r + 0);
  for (std::size_t k = 0; k < axes; ++k)  // two's complement, as the MCU's int16_t
    out.command[k] = static_cast<std::int16_t>(u16le(r + 2 + 2 * k));
  const std::uint8_t* tail = r + 2 + 2 * axes;
  out.enable = (tail[0] & 0x01U) != 0;
  out.reset = (tail[0] & 0x02U) != 0;
  out.deadman_us = u16le(tail + 2);
  return true;
}

std::size_t write_in_report(const BoardStatus& status, std::span<std::uint8_t> buffer,
                            std::size_t axes) noexcept {
  const std::size_t size = in_report_bytes_for(axes);
  if (axes < 1 || axes > max_board_axes || buffer.size() < size) return 0;
  std::uint8_t* r = buffer.data();
  std::memset(r, 0, size);
  put_u16le(r + 0, status.sequence);
  put_u16le(r + 2, status.ack);
  for (std::size_t k = 0; k < axes; ++k) {
    const auto position = static_cast<std::uint32_t>(status.position[k]);
    for (unsigned i = 0; i < 4; ++i) r[4 + 4 * k + i] = static_cast<std::uint8_t>(position >> (8U * i));
  }
  std::uint8_t* tail = r + 4 + 4 * axes;
  tail[0] = static_cast<std::uint8_t>((status.enabled ? 0x01U : 0U) | (status.fault ? 0x02U : 0U) |
                                      (status.watchdog ? 0x04U : 0U));
  tail[1] = status.fault_code;
  return size;
}

double command_to_force(std::int16_t command, double full_scale) noexcept {
  const std::int32_t counts = std::max<std::int32_t>(command, -command_full_scale_counts);
  return static_cast<double>(counts) / command_full_scale_counts * full_scale;
}

}  // namespace hapticd::drivers::usb_hid::sim
