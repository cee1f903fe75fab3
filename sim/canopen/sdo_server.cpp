#include "sim/canopen/sdo_server.hpp"

namespace hapticd::drivers::canopen::sim {

namespace {

// Client and server command specifiers (bits 7..5 of byte 0).
constexpr std::uint8_t ccs_initiate_download = 1;
constexpr std::uint8_t ccs_initiate_upload = 2;
constexpr std::uint8_t ccs_abort = 4;
constexpr std::uint8_t scs_initiate_upload = 2;
constexpr std::uint8_t scs_initiate_download = 3;
constexpr std::uint8_t cs_abort = 4;
constexpr std::uint8_t bit_e = 1U << 1;  ///< expedited
constexpr std::uint8_t bit_s = 1U << 0;  ///< size indicated

Frame response(std::uint8_t node, std::uint8_t command, Address address) noexcept {
  Frame f;
  f.id = can_id(function_code::sdo_server_to_client, node);
  f.len = 8;
  f.data[0] = command;
  put_le(f, 1, address.index, 2);
  f.data[3] = address.sub;
  return f;
}

}  // namespace

std::optional<SdoRequest> parse_sdo_request(const Frame& frame) noexcept {
  if (!is_data_frame(frame) || frame.len != 8) return std::nullopt;
  SdoRequest r;
  const std::uint8_t command = frame.data[0];
  r.address = {static_cast<std::uint16_t>(get_le(frame, 1, 2)), frame.data[3]};
  switch (command >> 5) {
    case ccs_initiate_upload:
      r.kind = SdoRequest::Kind::upload;
      return r;
    case ccs_initiate_download:
      if ((command & bit_e) == 0) {
        r.kind = SdoRequest::Kind::segmented_or_block;
        return r;
      }
      r.kind = SdoRequest::Kind::expedited_download;
      // n: the bytes of 4..7 that hold no data, meaningful only with s = 1.
      r.size = (command & bit_s) != 0 ? static_cast<std::uint8_t>(4 - (command >> 2 & 0x3U)) : 0;
      r.data = get_le(frame, 4, r.size == 0 ? 4 : r.size);
      return r;
    case ccs_abort:
      r.kind = SdoRequest::Kind::client_abort;
      r.data = get_le(frame, 4, 4);
      return r;
    case 0:  // download segment
    case 3:  // upload segment
    case 5:  // block upload
    case 6:  // block download
      r.kind = SdoRequest::Kind::segmented_or_block;
      return r;
    default:
      r.kind = SdoRequest::Kind::unknown;
      return r;
  }
}

Frame upload_response(std::uint8_t node, Address address, std::uint32_t value, std::uint8_t size) noexcept {
  const auto n = static_cast<std::uint8_t>(4 - size);
  Frame f =
      response(node, static_cast<std::uint8_t>(scs_initiate_upload << 5 | n << 2 | bit_e | bit_s), address);
  put_le(f, 4, value, size);
  return f;
}

Frame download_response(std::uint8_t node, Address address) noexcept {
  return response(node, static_cast<std::uint8_t>(scs_initiate_download << 5), address);
}

Frame abort_response(std::uint8_t node, Address address, std::uint32_t code) noexcept {
  Frame f = response(node, static_cast<std::uint8_t>(cs_abort << 5), address);
  put_le(f, 4, code, 4);
  return f;
}

std::string_view abort_words(std::uint32_t code) noexcept {
  // CiA 301 Table 22, in the drive's words.
  static constexpr struct {
    std::uint32_t code;
    std::string_view words;
  } table[] = {
      {0x05030000, "toggle bit not alternated"},
      {0x05040000, "SDO protocol timed out"},
      {0x05040001, "client/server command specifier not valid or unknown"},
      {0x05040002, "invalid block size"},
      {0x05040003, "invalid sequence number"},
      {0x05040004, "CRC error"},
      {0x05040005, "out of memory"},
      {0x06010000, "unsupported access to an object"},
      {0x06010001, "attempt to read a write-only object"},
      {0x06010002, "attempt to write a read-only object"},
      {0x06020000, "object does not exist in the object dictionary"},
      {0x06040041, "object cannot be mapped to the PDO"},
      {0x06040042, "the mapped objects would exceed the PDO length"},
      {0x06040043, "general parameter incompatibility"},
      {0x06040047, "general internal incompatibility in the device"},
      {0x06060000, "access failed due to a hardware error"},
      {0x06070010, "data type does not match, length of service parameter does not match"},
      {0x06070012, "data type does not match, length of service parameter too high"},
      {0x06070013, "data type does not match, length of service parameter too low"},
      {0x06090011, "sub-index does not exist"},
      {0x06090030, "invalid value for parameter"},
      {0x06090031, "value of parameter written too high"},
      {0x06090032, "value of parameter written too low"},
      {0x06090036, "maximum value is less than minimum value"},
      {0x060A0023, "resource not available: SDO connection"},
      {0x08000000, "general error"},
      {0x08000020, "data cannot be transferred or stored to the application"},
      {0x08000021, "data cannot be stored because of local control"},
      {0x08000022, "data cannot be stored in the drive's present state"},
      {0x08000023, "object dictionary not present or its dynamic generation failed"},
      {0x08000024, "no data available"},
  };
  for (const auto& row : table)
    if (row.code == code) return row.words;
  return "not a CiA 301 abort code";
}

}  // namespace hapticd::drivers::canopen::sim
