#include "drivers/canopen/301/sdo.hpp"

#include "drivers/canopen/301/cob_id.hpp"

namespace hapticd::drivers::canopen::cia301 {
namespace {

// Command specifier fields (CiA 301 SDO protocol).
constexpr std::uint8_t ccs_download_initiate = 1;  // client: 001
constexpr std::uint8_t ccs_upload_initiate = 2;    // client: 010
constexpr std::uint8_t scs_upload_initiate = 2;    // server: 010
constexpr std::uint8_t scs_download_initiate = 3;  // server: 011
constexpr std::uint8_t cs_abort = 4;               // either: 100
constexpr std::uint8_t bit_expedited = 0x02;
constexpr std::uint8_t bit_size = 0x01;

constexpr std::uint8_t specifier(std::uint8_t command) { return static_cast<std::uint8_t>(command >> 5); }

Frame sdo_frame(std::uint32_t id, std::uint8_t command, ObjectAddress address) noexcept {
  Frame f;
  f.id = id;
  f.len = 8;
  f.data[0] = command;
  put_le(f.data, 1, address.index, 2);
  f.data[3] = address.sub;
  return f;
}

// Expedited initiate with size: n = 4 - size in bits 3-2, e = s = 1.
constexpr std::uint8_t expedited_command(std::uint8_t cs, std::uint8_t size) {
  return static_cast<std::uint8_t>((cs << 5) | ((4U - size) << 2) | bit_expedited | bit_size);
}

constexpr std::uint32_t low_bytes(std::uint32_t value, std::uint8_t size) {
  return size >= 4 ? value : value & ((1U << (8U * size)) - 1U);
}

ObjectAddress address_of(const Frame& f) {
  return {static_cast<std::uint16_t>(get_le(f.data, 1, 2)), f.data[3]};
}

// Data bytes of an expedited initiate: 1..4 when s = 1, 0 when not indicated.
std::uint8_t expedited_size(std::uint8_t command) {
  if ((command & bit_size) == 0) return 0;
  return static_cast<std::uint8_t>(4U - ((command >> 2) & 0x03U));
}

}  // namespace

std::string_view describe_abort(std::uint32_t code) noexcept {
  switch (code) {
    case abort_code::toggle_bit:
      return "toggle bit not alternated";
    case abort_code::timed_out:
      return "SDO protocol timed out";
    case abort_code::unknown_command:
      return "command specifier not valid or unknown";
    case 0x05040002:
      return "invalid block size";
    case 0x05040003:
      return "invalid sequence number";
    case 0x05040004:
      return "CRC error";
    case abort_code::out_of_memory:
      return "out of memory";
    case abort_code::unsupported_access:
      return "unsupported access to the object";
    case abort_code::write_only:
      return "the object is write-only";
    case abort_code::read_only:
      return "the object is read-only";
    case abort_code::no_object:
      return "the object does not exist in the object dictionary";
    case abort_code::not_mappable:
      return "the object cannot be mapped to the PDO";
    case abort_code::mapping_too_long:
      return "the mapped objects would exceed the PDO length";
    case abort_code::parameter_incompatible:
      return "general parameter incompatibility";
    case abort_code::device_incompatible:
      return "general internal incompatibility in the device";
    case abort_code::hardware_error:
      return "access failed due to a hardware error";
    case abort_code::length_mismatch:
      return "data type does not match: length of the value does not match";
    case abort_code::length_too_high:
      return "data type does not match: value too long";
    case abort_code::length_too_low:
      return "data type does not match: value too short";
    case abort_code::no_sub_index:
      return "the sub-index does not exist";
    case abort_code::invalid_value:
      return "invalid value for the parameter";
    case abort_code::value_too_high:
      return "value too high";
    case abort_code::value_too_low:
      return "value too low";
    case abort_code::max_below_min:
      return "maximum value is less than minimum value";
    case abort_code::no_resource:
      return "resource not available: SDO connection";
    case abort_code::general:
      return "general error";
    case abort_code::cannot_store:
      return "data cannot be transferred or stored to the application";
    case abort_code::local_control:
      return "data cannot be stored because of local control";
    case abort_code::wrong_state:
      return "data cannot be stored in the drive's present state";
    case abort_code::no_dictionary:
      return "no object dictionary present";
    case abort_code::no_data:
      return "no data available";
    default:
      return "abort code not defined by CiA 301";
  }
}

Frame encode_upload_request(std::uint8_t node, ObjectAddress address) noexcept {
  return sdo_frame(sdo_request_id(node), static_cast<std::uint8_t>(ccs_upload_initiate << 5), address);
}

Frame encode_download_expedited(std::uint8_t node, ObjectAddress address, std::uint32_t value,
                                std::uint8_t size) noexcept {
  if (size < 1) size = 1;
  if (size > 4) size = 4;
  Frame f = sdo_frame(sdo_request_id(node), expedited_command(ccs_download_initiate, size), address);
  put_le(f.data, 4, low_bytes(value, size), size);
  return f;
}

Frame encode_client_abort(std::uint8_t node, ObjectAddress address, std::uint32_t code) noexcept {
  Frame f = sdo_frame(sdo_request_id(node), static_cast<std::uint8_t>(cs_abort << 5), address);
  put_le(f.data, 4, code, 4);
  return f;
}

std::optional<SdoResponse> decode_sdo_response(const Frame& frame, std::uint8_t node) noexcept {
  if (!is_standard_data_frame(frame) || frame.id != sdo_response_id(node) || frame.len != 8)
    return std::nullopt;
  SdoResponse r;
  r.command = frame.data[0];
  r.address = address_of(frame);
  switch (specifier(r.command)) {
    case scs_upload_initiate:
      if ((r.command & bit_expedited) != 0) {
        r.kind = SdoResponse::Kind::upload_expedited;
        r.size = expedited_size(r.command);
        r.value = get_le(frame.data, 4, r.size == 0 ? 4 : r.size);
      } else {
        r.kind = SdoResponse::Kind::upload_segmented;
        r.value = (r.command & bit_size) != 0 ? get_le(frame.data, 4, 4) : 0;
      }
      break;
    case scs_download_initiate:
      r.kind = SdoResponse::Kind::download_ack;
      break;
    case cs_abort:
      r.kind = SdoResponse::Kind::abort;
      r.abort_code = get_le(frame.data, 4, 4);
      break;
    default:
      r.kind = SdoResponse::Kind::unknown;
      break;
  }
  return r;
}

std::optional<SdoRequest> decode_sdo_request(const Frame& frame, std::uint8_t node) noexcept {
  if (!is_standard_data_frame(frame) || frame.id != sdo_request_id(node) || frame.len != 8)
    return std::nullopt;
  SdoRequest r;
  r.command = frame.data[0];
  r.address = address_of(frame);
  switch (specifier(r.command)) {
    case ccs_upload_initiate:
      r.kind = SdoRequest::Kind::upload;
      break;
    case ccs_download_initiate:
      if ((r.command & bit_expedited) != 0) {
        r.kind = SdoRequest::Kind::download_expedited;
        r.size = expedited_size(r.command);
        r.value = get_le(frame.data, 4, r.size == 0 ? 4 : r.size);
      } else {
        r.kind = SdoRequest::Kind::download_segmented;
        r.value = (r.command & bit_size) != 0 ? get_le(frame.data, 4, 4) : 0;
      }
      break;
    case cs_abort:
      r.kind = SdoRequest::Kind::abort;
      r.abort_code = get_le(frame.data, 4, 4);
      break;
    default:
      r.kind = SdoRequest::Kind::unknown;
      break;
  }
  return r;
}

Frame encode_upload_response(std::uint8_t node, ObjectAddress address, std::uint32_t value,
                             std::uint8_t size) noexcept {
  if (size < 1) size = 1;
  if (size > 4) size = 4;
  Frame f = sdo_frame(sdo_response_id(node), expedited_command(scs_upload_initiate, size), address);
  put_le(f.data, 4, low_bytes(value, size), size);
  return f;
}

Frame encode_download_response(std::uint8_t node, ObjectAddress address) noexcept {
  return sdo_frame(sdo_response_id(node), static_cast<std::uint8_t>(scs_download_initiate << 5), address);
}

Frame encode_server_abort(std::uint8_t node, ObjectAddress address, std::uint32_t code) noexcept {
  Frame f = sdo_frame(sdo_response_id(node), static_cast<std::uint8_t>(cs_abort << 5), address);
  put_le(f.data, 4, code, 4);
  return f;
}

}  // namespace hapticd::drivers::canopen::cia301
