#include "drivers/usb_hid/report_codec.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <vector>

namespace hapticd::drivers::usb_hid {

namespace {

constexpr std::string_view integer_types_help =
    "OFFSET:TYPE with TYPE one of u8 i8 u16le u16be i16le i16be u32le u32be i32le i32be (e.g. \"4:i32le\")";

struct TypeName {
  std::string_view name;
  std::uint8_t size;
  bool is_signed;
  ByteOrder order;
};
constexpr std::array<TypeName, 10> type_names{{
    {"u8", 1, false, ByteOrder::little},
    {"i8", 1, true, ByteOrder::little},
    {"u16le", 2, false, ByteOrder::little},
    {"u16be", 2, false, ByteOrder::big},
    {"i16le", 2, true, ByteOrder::little},
    {"i16be", 2, true, ByteOrder::big},
    {"u32le", 4, false, ByteOrder::little},
    {"u32be", 4, false, ByteOrder::big},
    {"i32le", 4, true, ByteOrder::little},
    {"i32be", 4, true, ByteOrder::big},
}};

bool parse_unsigned(std::string_view text, std::size_t& out) {
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc{} && end == text.data() + text.size();
}

}  // namespace

std::int64_t IntegerField::largest() const noexcept {
  if (size == 0) return 0;
  return is_signed ? (std::int64_t{1} << (bits() - 1)) - 1 : (std::int64_t{1} << bits()) - 1;
}

std::uint32_t IntegerField::mask() const noexcept {
  return size >= 4 ? 0xFFFFFFFFU : static_cast<std::uint32_t>((1U << bits()) - 1U);
}

std::size_t axis_count(const AxisFields& fields) noexcept {
  std::size_t n = 0;
  while (n < fields.size() && fields[n].present()) ++n;
  return n;
}

AxisFields consecutive_fields(const IntegerField& first, std::size_t axes) noexcept {
  AxisFields out{};
  for (std::size_t k = 0; k < axes && k < out.size(); ++k) {
    out[k] = first;
    out[k].offset = first.offset + k * first.size;
  }
  return out;
}

IntegerField parse_integer_field(std::string_view text) {
  if (text == "none") return IntegerField{};
  const auto colon = text.find(':');
  std::size_t offset = 0;
  if (colon == std::string_view::npos || !parse_unsigned(text.substr(0, colon), offset) ||
      offset >= max_report_size)
    throw std::invalid_argument("\"" + std::string(text) +
                                "\" is not a field; accepted: " + std::string(integer_types_help) +
                                ", OFFSET 0.." + std::to_string(max_report_size - 1) + ", or \"none\"");
  const std::string_view type = text.substr(colon + 1);
  for (const TypeName& t : type_names)
    if (t.name == type) return IntegerField{offset, t.size, t.is_signed, t.order};
  throw std::invalid_argument("\"" + std::string(text) + "\": unknown type \"" + std::string(type) +
                              "\"; accepted: " + std::string(integer_types_help));
}

BitField parse_bit_field(std::string_view text) {
  if (text == "none") return BitField{};
  const auto dot = text.find('.');
  std::size_t offset = 0, bit = 0;
  if (dot == std::string_view::npos || !parse_unsigned(text.substr(0, dot), offset) ||
      !parse_unsigned(text.substr(dot + 1), bit) || bit > 7 || offset >= max_report_size)
    throw std::invalid_argument("\"" + std::string(text) +
                                "\" is not a bit; accepted: OFFSET.BIT with OFFSET 0.." +
                                std::to_string(max_report_size - 1) +
                                " and BIT 0..7 (0 = least significant), e.g. \"8.1\", or \"none\"");
  return bit_at(offset, static_cast<std::uint8_t>(bit));
}

std::string to_string(const IntegerField& f) {
  if (!f.present()) return "none";
  for (const TypeName& t : type_names)
    if (t.size == f.size && t.is_signed == f.is_signed && (t.size == 1 || t.order == f.order))
      return std::to_string(f.offset) + ":" + std::string(t.name);
  return "invalid";
}

std::string to_string(const BitField& b) {
  if (!b.present) return "none";
  return std::to_string(b.offset) + "." + std::to_string(b.bit);
}

std::int64_t read_field(std::span<const std::uint8_t> report, const IntegerField& f) noexcept {
  std::uint32_t raw = 0;
  for (std::size_t i = 0; i < f.size; ++i) {
    const std::size_t index = f.order == ByteOrder::little ? f.offset + f.size - 1 - i : f.offset + i;
    raw = (raw << 8) | report[index];
  }
  if (f.is_signed && f.size < 4 && (raw >> (f.bits() - 1)) != 0) raw |= ~f.mask();  // sign-extend
  return f.is_signed ? static_cast<std::int64_t>(static_cast<std::int32_t>(raw)) : std::int64_t{raw};
}

void write_field(std::span<std::uint8_t> report, const IntegerField& f, std::int64_t value) noexcept {
  auto raw = static_cast<std::uint32_t>(static_cast<std::uint64_t>(value) & f.mask());
  for (std::size_t i = 0; i < f.size; ++i) {
    const std::size_t index = f.order == ByteOrder::little ? f.offset + i : f.offset + f.size - 1 - i;
    report[index] = static_cast<std::uint8_t>(raw & 0xFFU);
    raw >>= 8;
  }
}

bool read_bit(std::span<const std::uint8_t> report, const BitField& b) noexcept {
  return ((report[b.offset] >> b.bit) & 1U) != 0;
}

void write_bit(std::span<std::uint8_t> report, const BitField& b, bool value) noexcept {
  const auto mask = static_cast<std::uint8_t>(1U << b.bit);
  report[b.offset] =
      static_cast<std::uint8_t>(value ? (report[b.offset] | mask) : (report[b.offset] & ~mask));
}

namespace {

/// Bit occupancy of one report while validating: which key owns each bit.
class Occupancy {
 public:
  Occupancy(std::string_view report, std::size_t size) : report_(report), size_(size), owner_(size * 8) {}

  /// `label` names the field in the words ("in_position (axis 2)"), `key` is the config key.
  void claim_bytes(const std::string& key, std::size_t offset, std::size_t count,
                   const std::string& label = {}) {
    const std::string& name = label.empty() ? key : label;
    if (offset + count > size_)
      throw LayoutError(key, name + " needs bytes " + std::to_string(offset) + ".." +
                                 std::to_string(offset + count - 1) + " but the " + std::string(report_) +
                                 " report has " + std::to_string(size_) + " bytes");
    for (std::size_t bit = offset * 8; bit < (offset + count) * 8; ++bit) claim_bit(key, name, bit);
  }
  void claim(const std::string& key, const IntegerField& f, const std::string& label = {}) {
    if (f.present()) claim_bytes(key, f.offset, f.size, label);
  }
  void claim(const std::string& key, const BitField& b) {
    if (!b.present) return;
    if (b.offset >= size_)
      throw LayoutError(key, key + " is in byte " + std::to_string(b.offset) + " but the " +
                                 std::string(report_) + " report has " + std::to_string(size_) + " bytes");
    claim_bit(key, key, b.offset * 8 + b.bit);
  }

 private:
  void claim_bit(const std::string& key, const std::string& name, std::size_t bit) {
    if (!owner_[bit].empty() && owner_[bit] != name)
      throw LayoutError(key, name + " overlaps " + owner_[bit] + " (byte " + std::to_string(bit / 8) +
                                 ", bit " + std::to_string(bit % 8) + ")");
    owner_[bit] = name;
  }
  std::string_view report_;
  std::size_t size_;
  std::vector<std::string> owner_;
};

void check_size(const std::string& key, std::size_t size) {
  if (size < 1 || size > max_report_size)
    throw LayoutError(key, key + " = " + std::to_string(size) + " is out of range; accepted: 1 to " +
                               std::to_string(max_report_size) + " bytes");
}

void check_report_id(const std::string& key, int id, Occupancy& occupancy) {
  if (id == no_report_id) return;
  if (id < 0 || id > 255)
    throw LayoutError(key,
                      key + " = " + std::to_string(id) + " is out of range; accepted: 0..255 or -1 (none)");
  occupancy.claim_bytes(key, 0, 1);
}

void require(const std::string& key, bool present, std::string_view what) {
  if (!present)
    throw LayoutError(key, key + " is required (" + std::string(what) + "); \"none\" is not accepted");
}

void require_unsigned(const std::string& key, const IntegerField& f) {
  if (f.present() && f.is_signed)
    throw LayoutError(key, key + " = \"" + to_string(f) + "\" must be unsigned (u8, u16le/be, u32le/be)");
}

/// The present fields lead (no axis given after a missing one); returns how many.
std::size_t check_axis_fields(const std::string& key, const AxisFields& fields) {
  const std::size_t n = axis_count(fields);
  for (std::size_t k = n; k < fields.size(); ++k)
    if (fields[k].present())
      throw LayoutError(key, key + " gives axis " + std::to_string(k + 1) + " but not axis " +
                                 std::to_string(n + 1) + "; accepted: 1 to " +
                                 std::to_string(max_report_axes) + " fields, one per axis, axis 1 first");
  return n;
}

/// "in_position" for one axis (the words of a one-axis layout stay as they
/// were), "in_position (axis 2)" with several.
std::string axis_label(const std::string& key, std::size_t axis, std::size_t axes) {
  return axes == 1 ? key : key + " (axis " + std::to_string(axis + 1) + ")";
}

void check_commands(const OutLayout& out, std::size_t axes) {
  const std::size_t commands = check_axis_fields("out_command", out.command);
  for (std::size_t k = 0; k < commands; ++k)
    if (!out.command[k].is_signed)
      throw LayoutError("out_command",
                        axis_label("out_command", k, commands) + " = \"" + to_string(out.command[k]) +
                            "\" must be signed (i8, i16le/be, i32le/be): the command is a signed "
                            "duty or torque");
  if (commands != axes)
    throw LayoutError("out_command", "out_command has " + std::to_string(commands) + " field" +
                                         (commands == 1 ? "" : "s") + " but in_position has " +
                                         std::to_string(axes) + "; accepted: one command per axis");
}

}  // namespace

void validate(const ReportLayout& layout) {
  const InLayout& in = layout.in;
  check_size("in_report_size", in.size);
  require("in_sequence", in.sequence.present(), "stale reports are detected by it");
  require("in_position", in.position[0].present(), "the encoder count");
  const std::size_t axes = check_axis_fields("in_position", in.position);
  require_unsigned("in_sequence", in.sequence);
  require_unsigned("in_ack", in.ack);
  Occupancy in_bits("IN", in.size);
  check_report_id("in_report_id", in.report_id, in_bits);
  in_bits.claim("in_sequence", in.sequence);
  in_bits.claim("in_ack", in.ack);
  for (std::size_t k = 0; k < axes; ++k)
    in_bits.claim("in_position", in.position[k], axis_label("in_position", k, axes));
  in_bits.claim("in_enabled_bit", in.enabled);
  in_bits.claim("in_fault_bit", in.fault);
  in_bits.claim("in_watchdog_bit", in.watchdog);
  in_bits.claim("in_fault_code", in.fault_code);

  const OutLayout& out = layout.out;
  check_size("out_report_size", out.size);
  require("out_sequence", out.sequence.present(), "the board's dead-man watches it");
  require("out_command", out.command[0].present(), "the signed duty or torque");
  require("out_enable_bit", out.enable.present, "the power stage is off unless it is set");
  require_unsigned("out_sequence", out.sequence);
  require_unsigned("out_deadman", out.deadman);
  check_commands(out, axes);
  Occupancy out_bits("OUT", out.size);
  check_report_id("out_report_id", out.report_id, out_bits);
  out_bits.claim("out_sequence", out.sequence);
  for (std::size_t k = 0; k < axes; ++k)
    out_bits.claim("out_command", out.command[k], axis_label("out_command", k, axes));
  out_bits.claim("out_enable_bit", out.enable);
  out_bits.claim("out_reset_bit", out.reset);
  out_bits.claim("out_deadman", out.deadman);
}

DecodeStatus decode_in(std::span<const std::uint8_t> bytes, const InLayout& layout, InReport& out) noexcept {
  if (bytes.size() < layout.size) return DecodeStatus::short_report;
  if (layout.report_id != no_report_id && bytes[0] != layout.report_id) return DecodeStatus::wrong_report_id;
  out = InReport{};
  out.sequence = static_cast<std::uint32_t>(read_field(bytes, layout.sequence));
  if (layout.ack.present()) out.ack = static_cast<std::uint32_t>(read_field(bytes, layout.ack));
  for (std::size_t k = 0; k < layout.position.size() && layout.position[k].present(); ++k)
    out.position_counts[k] = read_field(bytes, layout.position[k]);
  if (layout.enabled.present) out.enabled = read_bit(bytes, layout.enabled);
  if (layout.fault.present) out.fault = read_bit(bytes, layout.fault);
  if (layout.watchdog.present) out.watchdog = read_bit(bytes, layout.watchdog);
  if (layout.fault_code.present())
    out.fault_code = static_cast<std::uint32_t>(read_field(bytes, layout.fault_code));
  return DecodeStatus::ok;
}

std::size_t encode_out(const OutReport& report, const OutLayout& layout,
                       std::span<std::uint8_t> buffer) noexcept {
  if (buffer.size() < layout.size) return 0;
  const std::span<std::uint8_t> bytes = buffer.first(layout.size);
  for (std::uint8_t& b : bytes) b = 0;
  if (layout.report_id != no_report_id) bytes[0] = static_cast<std::uint8_t>(layout.report_id);
  write_field(bytes, layout.sequence, report.sequence);
  for (std::size_t k = 0; k < layout.command.size() && layout.command[k].present(); ++k)
    write_field(bytes, layout.command[k], report.command[k]);
  write_bit(bytes, layout.enable, report.enable);
  if (layout.reset.present) write_bit(bytes, layout.reset, report.reset);
  if (layout.deadman.present()) write_field(bytes, layout.deadman, report.deadman_us);
  return layout.size;
}

DecodeStatus decode_out(std::span<const std::uint8_t> bytes, const OutLayout& layout,
                        OutReport& out) noexcept {
  if (bytes.size() < layout.size) return DecodeStatus::short_report;
  if (layout.report_id != no_report_id && bytes[0] != layout.report_id) return DecodeStatus::wrong_report_id;
  out = OutReport{};
  out.sequence = static_cast<std::uint32_t>(read_field(bytes, layout.sequence));
  for (std::size_t k = 0; k < layout.command.size() && layout.command[k].present(); ++k)
    out.command[k] = read_field(bytes, layout.command[k]);
  out.enable = read_bit(bytes, layout.enable);
  if (layout.reset.present) out.reset = read_bit(bytes, layout.reset);
  if (layout.deadman.present())
    out.deadman_us = static_cast<std::uint32_t>(read_field(bytes, layout.deadman));
  return DecodeStatus::ok;
}

std::size_t encode_in(const InReport& report, const InLayout& layout,
                      std::span<std::uint8_t> buffer) noexcept {
  if (buffer.size() < layout.size) return 0;
  const std::span<std::uint8_t> bytes = buffer.first(layout.size);
  for (std::uint8_t& b : bytes) b = 0;
  if (layout.report_id != no_report_id) bytes[0] = static_cast<std::uint8_t>(layout.report_id);
  write_field(bytes, layout.sequence, report.sequence);
  if (layout.ack.present()) write_field(bytes, layout.ack, report.ack);
  for (std::size_t k = 0; k < layout.position.size() && layout.position[k].present(); ++k)
    write_field(bytes, layout.position[k], report.position_counts[k]);
  if (layout.enabled.present) write_bit(bytes, layout.enabled, report.enabled);
  if (layout.fault.present) write_bit(bytes, layout.fault, report.fault);
  if (layout.watchdog.present) write_bit(bytes, layout.watchdog, report.watchdog);
  if (layout.fault_code.present()) write_field(bytes, layout.fault_code, report.fault_code);
  return layout.size;
}

std::int64_t sequence_distance(std::uint32_t from, std::uint32_t to, const IntegerField& f) noexcept {
  const std::uint64_t modulus = std::uint64_t{f.mask()} + 1;
  const std::uint64_t forward = (std::uint64_t{to} - from) & f.mask();
  return forward > modulus / 2 ? static_cast<std::int64_t>(forward) - static_cast<std::int64_t>(modulus)
                               : static_cast<std::int64_t>(forward);
}

std::uint32_t next_sequence(std::uint32_t s, const IntegerField& f) noexcept { return (s + 1U) & f.mask(); }

std::int64_t command_counts(double force, double full_scale, const IntegerField& command) noexcept {
  if (!std::isfinite(force) || !(full_scale > 0.0)) return 0;
  const auto largest = static_cast<double>(command.largest());
  const double scaled = std::round(force / full_scale * largest);
  if (scaled >= largest) return command.largest();
  if (scaled <= -largest) return -command.largest();
  return static_cast<std::int64_t>(scaled);
}

double command_force(std::int64_t counts, double full_scale, const IntegerField& command) noexcept {
  return static_cast<double>(counts) / static_cast<double>(command.largest()) * full_scale;
}

std::string fault_code_text(std::uint32_t code) {
  const auto known = static_cast<BoardFaultCode>(code <= 7U ? code : 0xFFU);
  switch (known) {
    case BoardFaultCode::none:
      return "no fault code";
    case BoardFaultCode::over_current:
      return "over-current";
    case BoardFaultCode::over_temperature:
      return "over-temperature";
    case BoardFaultCode::under_voltage:
      return "supply under-voltage";
    case BoardFaultCode::over_voltage:
      return "supply over-voltage";
    case BoardFaultCode::encoder:
      return "encoder error";
    case BoardFaultCode::watchdog:
      return "dead-man watchdog (no new OUT report in time)";
    case BoardFaultCode::emergency_stop:
      return "emergency-stop input";
    default:
      break;
  }
  char text[64];
  std::snprintf(text, sizeof text, "code 0x%02x (not in the protocol's table)", static_cast<unsigned>(code));
  return text;
}

}  // namespace hapticd::drivers::usb_hid
