#pragma once
/// \file
/// The board's own reading of its reports, written from the protocol note's
/// tables (drivers/usb_hid/README.md "Reports", "Status and fault codes"),
/// not with the driver's report codec: a misreading of the layout in either
/// then shows as a failure instead of passing both ends. The board speaks
/// the default layout, byte by byte as a firmware would (no report ID):
///
///   IN, 16 bytes:  0-1 sequence u16le | 2-3 ack u16le | 4-7 position i32le |
///                  8 bit 0 enabled, bit 1 fault, bit 2 watchdog | 9 fault code |
///                  10-15 reserved 0
///   OUT, 8 bytes:  0-1 sequence u16le | 2-3 command i16le (+-32767 = full
///                  scale) | 4 bit 0 enable, bit 1 reset | 5 reserved |
///                  6-7 dead-man us u16le
///
/// A board with N axes (2 to 6) speaks the same reports with one encoder and
/// one command per axis, consecutive, and the fields after them moved down:
///
///   IN, max(16, 6 + 4N) bytes: 0-1 sequence | 2-3 ack | 4 + 4k position of
///                  axis k (i32le) | 4 + 4N status bits | 5 + 4N fault code
///   OUT, 6 + 2N bytes: 0-1 sequence | 2 + 2k command of axis k (i16le) |
///                  2 + 2N enable, reset | 3 + 2N reserved | 4 + 2N dead-man
///
/// (N = 1 is the default layout above.) Pure and allocation-free.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace hapticd::drivers::usb_hid::sim {

inline constexpr std::size_t in_report_bytes = 16;
inline constexpr std::size_t out_report_bytes = 8;
/// The most axes a board carries, and its reports' largest sizes.
inline constexpr std::size_t max_board_axes = 6;
inline constexpr std::size_t max_in_report_bytes = 6 + 4 * max_board_axes;
/// The reports of a board with `axes` axes (1 to max_board_axes).
constexpr std::size_t in_report_bytes_for(std::size_t axes) { return 6 + 4 * axes > 16 ? 6 + 4 * axes : 16; }
constexpr std::size_t out_report_bytes_for(std::size_t axes) { return 6 + 2 * axes; }
/// The command's full scale in counts: +-32767 (-32768 is never sent).
inline constexpr std::int32_t command_full_scale_counts = 32767;

/// The fault codes of the protocol's table.
enum class FaultCode : std::uint8_t {
  none = 0,
  over_current = 1,
  over_temperature = 2,
  under_voltage = 3,
  over_voltage = 4,
  encoder = 5,
  watchdog = 6,  ///< the dead-man: no new OUT report in time
  emergency_stop = 7,
};

/// What the host sends (OUT report).
struct BoardCommand {
  std::uint16_t sequence = 0;
  std::array<std::int16_t, max_board_axes> command{};  ///< per axis
  bool enable = false;
  bool reset = false;
  std::uint16_t deadman_us = 0;
};

/// What the board answers (IN report).
struct BoardStatus {
  std::uint16_t sequence = 0;
  std::uint16_t ack = 0;
  std::array<std::int32_t, max_board_axes> position{};  ///< per axis
  bool enabled = false;
  bool fault = false;
  bool watchdog = false;
  std::uint8_t fault_code = 0;
};

/// False (and `out` untouched) for a report shorter than
/// out_report_bytes_for(axes) (8 bytes for one axis).
bool read_out_report(std::span<const std::uint8_t> bytes, BoardCommand& out, std::size_t axes = 1) noexcept;
/// in_report_bytes_for(axes) bytes (16 for one axis), reserved bytes 0;
/// returns 0 if `buffer` is shorter.
std::size_t write_in_report(const BoardStatus& status, std::span<std::uint8_t> buffer,
                            std::size_t axes = 1) noexcept;
/// The amplifier's force (N or N m) for a command: counts / 32767 x full
/// scale; -32768, which a host never sends, saturates at -full scale.
double command_to_force(std::int16_t command, double full_scale) noexcept;

}  // namespace hapticd::drivers::usb_hid::sim
