// libFuzzer target: the usb-hid report codec on what a config file and a
// board could hand it. Input: a position field spec ("4:i32le"), a newline,
// a fault bit spec ("8.1"), a newline, then the bytes of an IN report (the
// board's). Must hold: nothing crashes or reads out of bounds; a field spec
// that parses prints back to a spec that parses to the same field; a layout
// that validates decodes any report, and a decoded report encodes back to
// bytes that decode to the same report (sequence, position, bits, codes);
// the OUT side does the same for the report the host would send.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string_view>

#include "drivers/usb_hid/report_codec.hpp"

namespace {

namespace usb = hapticd::drivers::usb_hid;

void require(bool holds) {
  if (!holds) __builtin_trap();
}

std::string_view next_line(std::string_view& rest) {
  const std::size_t end = rest.find('\n');
  const std::string_view line = rest.substr(0, end);
  rest = end == std::string_view::npos ? std::string_view{} : rest.substr(end + 1);
  return line;
}

template <typename Field, typename Parse>
std::optional<Field> parsed(std::string_view text, Parse parse) {
  try {
    const Field f = parse(text);
    require(usb::to_string(parse(usb::to_string(f))) == usb::to_string(f));
    return f;
  } catch (const std::invalid_argument&) {
    return std::nullopt;
  }
}

std::optional<usb::ReportLayout> layout_from(std::string_view& rest) {
  usb::ReportLayout layout;
  const auto position = parsed<usb::IntegerField>(next_line(rest), usb::parse_integer_field);
  const auto fault = parsed<usb::BitField>(next_line(rest), usb::parse_bit_field);
  if (position) layout.in.position[0] = *position;
  if (fault) layout.in.fault = *fault;
  try {
    usb::validate(layout);
  } catch (const std::invalid_argument&) {
    return std::nullopt;
  }
  return layout;
}

void check_in(std::span<const std::uint8_t> bytes, const usb::InLayout& layout) {
  usb::InReport report;
  if (usb::decode_in(bytes, layout, report) != usb::DecodeStatus::ok) return;
  std::array<std::uint8_t, 256> buffer{};
  const std::size_t n = usb::encode_in(report, layout, buffer);
  require(n == layout.size);
  usb::InReport again;
  require(usb::decode_in(std::span(buffer).first(n), layout, again) == usb::DecodeStatus::ok);
  require(again == report);
}

void check_out(std::span<const std::uint8_t> bytes, const usb::OutLayout& layout) {
  usb::OutReport report;
  if (usb::decode_out(bytes, layout, report) != usb::DecodeStatus::ok) return;
  std::array<std::uint8_t, 256> buffer{};
  const std::size_t n = usb::encode_out(report, layout, buffer);
  require(n == layout.size);
  usb::OutReport again;
  require(usb::decode_out(std::span(buffer).first(n), layout, again) == usb::DecodeStatus::ok);
  require(again == report);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  const auto layout = layout_from(rest);
  if (!layout) return 0;
  const std::span<const std::uint8_t> bytes(reinterpret_cast<const std::uint8_t*>(rest.data()), rest.size());
  check_in(bytes, layout->in);
  check_out(bytes, layout->out);
  return 0;
}
