#pragma once
/// \file
/// The report layout of the usb-hid board protocol (README.md "Reports"):
/// where each field sits in the interrupt IN and OUT reports, and the pure
/// encode/decode of one report. No system calls, no allocation on the
/// per-report functions (they are called from the RT thread and from the
/// simulated board's firmware).
///
/// Field notation (the config keys use it, README.md gives the defaults):
///   integer  "OFFSET:TYPE"  TYPE = u8 i8 u16le u16be i16le i16be u32le u32be i32le i32be
///   bit      "OFFSET.BIT"   BIT 0..7, 0 = least significant
///   absent   "none"         (optional fields only)
/// USB itself sends multi-byte descriptor fields little-endian (USB 2.0
/// 8.1); a report's payload is the firmware's choice, hence the byte order.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace hapticd::drivers::usb_hid {

enum class ByteOrder : std::uint8_t { little, big };

/// An integer at a byte offset. size 0 = the field is absent.
struct IntegerField {
  std::size_t offset = 0;
  std::uint8_t size = 0;  ///< bytes: 1, 2 or 4 (0: absent)
  bool is_signed = false;
  ByteOrder order = ByteOrder::little;

  bool present() const noexcept { return size != 0; }
  unsigned bits() const noexcept { return 8U * size; }
  /// Largest magnitude a command may use: 2^(bits-1) - 1 signed (symmetric
  /// range, so +x and -x are both representable), 2^bits - 1 unsigned.
  std::int64_t largest() const noexcept;
  /// 2^bits - 1: sequence numbers wrap modulo 2^bits.
  std::uint32_t mask() const noexcept;
  friend bool operator==(const IntegerField&, const IntegerField&) = default;
};

/// One bit at a byte offset. present = false: the field is absent.
struct BitField {
  std::size_t offset = 0;
  std::uint8_t bit = 0;
  bool present = false;
  friend bool operator==(const BitField&, const BitField&) = default;
};

constexpr IntegerField field(std::size_t offset, std::uint8_t size, bool is_signed,
                             ByteOrder order = ByteOrder::little) {
  return IntegerField{offset, size, is_signed, order};
}
constexpr BitField bit_at(std::size_t offset, std::uint8_t bit) { return BitField{offset, bit, true}; }

/// Parses "4:i32le" / "none" (throws std::invalid_argument naming what is accepted).
IntegerField parse_integer_field(std::string_view text);
/// Parses "8.1" / "none".
BitField parse_bit_field(std::string_view text);
std::string to_string(const IntegerField& f);  ///< "4:i32le", "none"
std::string to_string(const BitField& f);      ///< "8.1", "none"

/// Reads the field (sign-extended when signed). The field must lie inside `report`.
std::int64_t read_field(std::span<const std::uint8_t> report, const IntegerField& f) noexcept;
/// Writes the low `bits()` bits of value (two's complement for negatives).
void write_field(std::span<std::uint8_t> report, const IntegerField& f, std::int64_t value) noexcept;
bool read_bit(std::span<const std::uint8_t> report, const BitField& b) noexcept;
void write_bit(std::span<std::uint8_t> report, const BitField& b, bool value) noexcept;

/// Largest report either direction may have: a full-speed interrupt
/// endpoint's wMaxPacketSize (USB 2.0 5.7.3); fixed-size buffers use it.
inline constexpr std::size_t max_report_size = 64;
/// report_id = no_report_id: the report has no ID byte.
inline constexpr int no_report_id = -1;
/// A board with several axes carries one encoder field and one command
/// field per axis (1 to 6: drivers::max_axes, checked in usb_hid_config.cpp).
inline constexpr std::size_t max_report_axes = 6;
/// One field per axis, axis 1 first; the present ones lead, the rest are absent.
using AxisFields = std::array<IntegerField, max_report_axes>;
/// How many leading fields are present (the axes the layout carries).
std::size_t axis_count(const AxisFields& fields) noexcept;
/// `first` for axis 1 and the next axes right after it, same type
/// (offset + k x size): the consecutive fields of `axes = N`.
AxisFields consecutive_fields(const IntegerField& first, std::size_t axes) noexcept;

/// Board -> host (interrupt IN). Defaults: README.md "IN report".
struct InLayout {
  std::size_t size = 16;
  int report_id = no_report_id;  ///< 0..255: byte 0 carries it
  IntegerField sequence = field(0, 2, false);
  IntegerField ack = field(2, 2, false);         ///< sequence of the last OUT report applied (optional)
  AxisFields position{field(4, 4, true)};        ///< each axis' encoder count (axis 1 at 4:i32le)
  BitField enabled = bit_at(8, 0);               ///< power stage on (optional)
  BitField fault = bit_at(8, 1);                 ///< board fault latched (optional)
  BitField watchdog = bit_at(8, 2);              ///< dead-man tripped (optional)
  IntegerField fault_code = field(9, 1, false);  ///< why (optional), table in fault_code_text()
  friend bool operator==(const InLayout&, const InLayout&) = default;
};

/// Host -> board (interrupt OUT). Defaults: README.md "OUT report".
struct OutLayout {
  std::size_t size = 8;
  int report_id = no_report_id;
  IntegerField sequence = field(0, 2, false);
  AxisFields command{field(2, 2, true)};  ///< each axis' signed duty or torque, full scale = largest()
  BitField enable = bit_at(4, 0);
  BitField reset = bit_at(4, 1);              ///< fault reset request (optional)
  IntegerField deadman = field(6, 2, false);  ///< dead-man timeout in microseconds (optional)
  friend bool operator==(const OutLayout&, const OutLayout&) = default;
};

struct ReportLayout {
  InLayout in;
  OutLayout out;
  /// The axes it carries: axis_count(in.position) (validate() checks the
  /// OUT report carries as many commands).
  std::size_t axes() const noexcept { return axis_count(in.position); }
  friend bool operator==(const ReportLayout&, const ReportLayout&) = default;
};

/// A layout that does not fit together. `key` is the config key to blame.
class LayoutError : public std::invalid_argument {
 public:
  LayoutError(std::string key, const std::string& message)
      : std::invalid_argument(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// Every field inside its report, no two fields sharing a bit, the report
/// ID byte free, the required fields present (sequence, position, command,
/// enable), sequences unsigned, the commands signed, as many commands as
/// positions (1 to max_report_axes, no gaps). Throws LayoutError naming the
/// key (`in_position` for any axis' encoder field, the message says which).
void validate(const ReportLayout& layout);

/// One decoded IN report.
struct InReport {
  std::uint32_t sequence = 0;
  std::uint32_t ack = 0;                                        ///< 0 when the layout has no ack field
  std::array<std::int64_t, max_report_axes> position_counts{};  ///< per axis; 0 past the layout's axes
  bool enabled = false;
  bool fault = false;
  bool watchdog = false;
  std::uint32_t fault_code = 0;
  friend bool operator==(const InReport&, const InReport&) = default;
};

/// One OUT report.
struct OutReport {
  std::uint32_t sequence = 0;
  std::array<std::int64_t, max_report_axes> command{};  ///< per axis; unused past the layout's axes
  bool enable = false;
  bool reset = false;
  std::uint32_t deadman_us = 0;
  friend bool operator==(const OutReport&, const OutReport&) = default;
};

enum class DecodeStatus : std::uint8_t {
  ok,
  short_report,     ///< fewer bytes than the layout's size
  wrong_report_id,  ///< byte 0 is not the layout's report ID
};

/// Host side: decode a received IN report.
DecodeStatus decode_in(std::span<const std::uint8_t> bytes, const InLayout& layout, InReport& out) noexcept;
/// Host side: encode an OUT report into `buffer` (zero-filled first).
/// Returns the report size, 0 if the buffer is smaller than the layout.
std::size_t encode_out(const OutReport& report, const OutLayout& layout,
                       std::span<std::uint8_t> buffer) noexcept;
/// Board side (the simulated firmware and the flashable sketch): the mirror images.
DecodeStatus decode_out(std::span<const std::uint8_t> bytes, const OutLayout& layout,
                        OutReport& out) noexcept;
std::size_t encode_in(const InReport& report, const InLayout& layout,
                      std::span<std::uint8_t> buffer) noexcept;

/// Signed distance from sequence `from` to `to` modulo 2^bits, in
/// (-2^(bits-1), 2^(bits-1)]: 1 = the next report, 0 = a repeat, < 0 = older.
std::int64_t sequence_distance(std::uint32_t from, std::uint32_t to, const IntegerField& f) noexcept;
std::uint32_t next_sequence(std::uint32_t s, const IntegerField& f) noexcept;

/// Force (N or N m) -> command counts: round(force / full_scale * largest),
/// saturated at +-largest. Non-finite force -> 0.
std::int64_t command_counts(double force, double full_scale, const IntegerField& command) noexcept;
/// Command counts -> force (the board side's view; full scale at largest()).
double command_force(std::int64_t counts, double full_scale, const IntegerField& command) noexcept;

/// Board fault codes of the protocol (README.md "Status and fault codes").
enum class BoardFaultCode : std::uint8_t {
  none = 0,
  over_current = 1,
  over_temperature = 2,
  under_voltage = 3,
  over_voltage = 4,
  encoder = 5,
  watchdog = 6,
  emergency_stop = 7,
};
/// "over-current", ...; "code 0x2a (not in the protocol's table)" for others.
std::string fault_code_text(std::uint32_t code);

}  // namespace hapticd::drivers::usb_hid
