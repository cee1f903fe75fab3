#include "drivers/canopen/301/emcy.hpp"

#include "drivers/canopen/301/cob_id.hpp"

namespace hapticd::drivers::canopen::cia301 {

Frame encode_emergency(std::uint8_t node, const Emergency& emcy) noexcept {
  Frame f;
  f.id = emcy_id(node);
  f.len = 8;
  put_le(f.data, 0, emcy.error_code, 2);
  f.data[2] = emcy.error_register;
  for (std::size_t i = 0; i < emcy.manufacturer.size(); ++i) f.data[3 + i] = emcy.manufacturer[i];
  return f;
}

std::optional<Emergency> decode_emergency(const Frame& frame, std::uint8_t node) noexcept {
  if (!is_standard_data_frame(frame) || frame.id != emcy_id(node) || frame.len != 8) return std::nullopt;
  Emergency e;
  e.error_code = static_cast<std::uint16_t>(get_le(frame.data, 0, 2));
  e.error_register = frame.data[2];
  for (std::size_t i = 0; i < e.manufacturer.size(); ++i) e.manufacturer[i] = frame.data[3 + i];
  return e;
}

std::string describe_error_register(std::uint8_t reg) {
  static constexpr std::pair<std::uint8_t, std::string_view> bits[] = {
      {error_register::generic, "generic"},
      {error_register::current, "current"},
      {error_register::voltage, "voltage"},
      {error_register::temperature, "temperature"},
      {error_register::communication, "communication"},
      {error_register::device_profile, "device profile"},
      {0x40, "reserved bit 6"},
      {error_register::manufacturer, "manufacturer-specific"}};
  std::string out;
  for (const auto& [bit, word] : bits) {
    if ((reg & bit) == 0) continue;
    if (!out.empty()) out += ", ";
    out += word;
  }
  return out.empty() ? "none" : out;
}

std::optional<std::string_view> describe_communication_error(std::uint16_t code) noexcept {
  switch (code) {
    case emcy_code::no_error:
      return "error reset or no error";
    case emcy_code::can_overrun:
      return "CAN overrun (objects lost)";
    case emcy_code::can_error_passive:
      return "CAN in error passive mode";
    case emcy_code::heartbeat:
      return "life guard or heartbeat error";
    case emcy_code::bus_off_recovered:
      return "recovered from bus off";
    case 0x8150:
      return "CAN-ID collision";
    case emcy_code::pdo_length:
      return "PDO not processed due to length error";
    case emcy_code::pdo_length_exceeded:
      return "PDO length exceeded";
    case 0x8230:
      return "DAM MPDO not processed, destination object not available";
    case 0x8240:
      return "unexpected SYNC data length";
    case emcy_code::rpdo_timeout:
      return "RPDO timeout";
    default:
      break;
  }
  switch (code & 0xFF00U) {
    case 0x8100:
      return "communication";
    case 0x8200:
      return "protocol error";
    default:
      return std::nullopt;
  }
}

std::string_view error_class(std::uint16_t code) noexcept {
  switch (code >> 12) {
    case 0x0:
      return "no error";
    case 0x1:
      return "generic error";
    case 0x2:
      return "current";
    case 0x3:
      return "voltage";
    case 0x4:
      return "temperature";
    case 0x5:
      return "device hardware";
    case 0x6:
      return "device software";
    case 0x7:
      return "additional modules";
    case 0x8:
      return "monitoring";
    case 0x9:
      return "external error";
    case 0xF:
      return (code & 0xFF00U) == 0xFF00U ? "device specific" : "additional functions";
    default:
      return "reserved error code class";
  }
}

}  // namespace hapticd::drivers::canopen::cia301
