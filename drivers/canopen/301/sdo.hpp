#pragma once
/// \file
/// CiA 301 SDO, the expedited subset (values of 1..4 bytes), both sides.
/// Every SDO frame has 8 bytes: byte 0 the command specifier, bytes 1-2 the
/// index (little-endian), byte 3 the sub-index, bytes 4-7 data or abort code.
///
///   client -> server (COB-ID 0x600 + node)        server -> client (0x580 + node)
///   upload request      0x40                       upload response  0x4F/0x4B/0x47/0x43 (1/2/3/4 bytes),
///                                                                   0x42 (expedited, size not indicated),
///                                                                   0x41 (segmented follows: size in 4-7)
///   download expedited  0x2F/0x2B/0x27/0x23        download response 0x60
///   abort (either way)  0x80, code in bytes 4-7
///
/// Command byte: ccs/scs in bits 7-5, n (bytes NOT holding data) in bits 3-2,
/// e (expedited) bit 1, s (size indicated) bit 0.

#include <cstdint>
#include <optional>
#include <string_view>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/301/object.hpp"

namespace hapticd::drivers::canopen::cia301 {

/// SDO abort codes (CiA 301) that the driver and the simulated drive use by name.
namespace abort_code {
inline constexpr std::uint32_t toggle_bit = 0x05030000;
inline constexpr std::uint32_t timed_out = 0x05040000;
inline constexpr std::uint32_t unknown_command = 0x05040001;
inline constexpr std::uint32_t out_of_memory = 0x05040005;
inline constexpr std::uint32_t unsupported_access = 0x06010000;
inline constexpr std::uint32_t write_only = 0x06010001;
inline constexpr std::uint32_t read_only = 0x06010002;
inline constexpr std::uint32_t no_object = 0x06020000;
inline constexpr std::uint32_t not_mappable = 0x06040041;
inline constexpr std::uint32_t mapping_too_long = 0x06040042;
inline constexpr std::uint32_t parameter_incompatible = 0x06040043;
inline constexpr std::uint32_t device_incompatible = 0x06040047;
inline constexpr std::uint32_t hardware_error = 0x06060000;
inline constexpr std::uint32_t length_mismatch = 0x06070010;
inline constexpr std::uint32_t length_too_high = 0x06070012;
inline constexpr std::uint32_t length_too_low = 0x06070013;
inline constexpr std::uint32_t no_sub_index = 0x06090011;
inline constexpr std::uint32_t invalid_value = 0x06090030;
inline constexpr std::uint32_t value_too_high = 0x06090031;
inline constexpr std::uint32_t value_too_low = 0x06090032;
inline constexpr std::uint32_t max_below_min = 0x06090036;
inline constexpr std::uint32_t no_resource = 0x060A0023;
inline constexpr std::uint32_t general = 0x08000000;
inline constexpr std::uint32_t cannot_store = 0x08000020;
inline constexpr std::uint32_t local_control = 0x08000021;
inline constexpr std::uint32_t wrong_state = 0x08000022;
inline constexpr std::uint32_t no_dictionary = 0x08000023;
inline constexpr std::uint32_t no_data = 0x08000024;
}  // namespace abort_code

/// The abort code in words ("object cannot be mapped to the PDO"); codes the
/// standard does not list: "abort code not defined by CiA 301".
std::string_view describe_abort(std::uint32_t code) noexcept;

// ---- client side -----------------------------------------------------------
Frame encode_upload_request(std::uint8_t node, ObjectAddress address) noexcept;
/// size: 1..4 bytes (the object's data type size); the value's low `size` bytes are sent.
Frame encode_download_expedited(std::uint8_t node, ObjectAddress address, std::uint32_t value,
                                std::uint8_t size) noexcept;
/// An abort the client sends (on the request COB-ID).
Frame encode_client_abort(std::uint8_t node, ObjectAddress address, std::uint32_t code) noexcept;

struct SdoResponse {
  enum class Kind : std::uint8_t {
    upload_expedited,  ///< value, size (0: expedited without size, 4 data bytes)
    upload_segmented,  ///< the object is longer than 4 bytes; value = size announced (if s = 1)
    download_ack,      ///< the write was accepted
    abort,             ///< abort_code
    unknown,           ///< a response this client does not understand (command byte in `command`)
  };
  Kind kind = Kind::unknown;
  ObjectAddress address;
  std::uint32_t value = 0;  ///< data (upload), announced size (segmented)
  std::uint8_t size = 0;    ///< data bytes indicated (1..4), 0 when not indicated
  std::uint32_t abort_code = 0;
  std::uint8_t command = 0;
};
/// Decodes a frame from `node`'s SDO server (COB-ID 0x580 + node, 8 bytes);
/// nullopt for any other frame.
std::optional<SdoResponse> decode_sdo_response(const Frame& frame, std::uint8_t node) noexcept;

// ---- server side -----------------------------------------------------------
struct SdoRequest {
  enum class Kind : std::uint8_t {
    upload,              ///< read `address`
    download_expedited,  ///< write value (size bytes, 0 = not indicated)
    download_segmented,  ///< a write of more than 4 bytes (not served by the expedited subset)
    abort,               ///< the client aborts: abort_code
    unknown,             ///< another command (segments, block transfer): command byte in `command`
  };
  Kind kind = Kind::unknown;
  ObjectAddress address;
  std::uint32_t value = 0;
  std::uint8_t size = 0;
  std::uint32_t abort_code = 0;
  std::uint8_t command = 0;
};
/// Decodes a frame addressed to `node`'s SDO server (COB-ID 0x600 + node).
std::optional<SdoRequest> decode_sdo_request(const Frame& frame, std::uint8_t node) noexcept;
/// size 1..4.
Frame encode_upload_response(std::uint8_t node, ObjectAddress address, std::uint32_t value,
                             std::uint8_t size) noexcept;
Frame encode_download_response(std::uint8_t node, ObjectAddress address) noexcept;
/// An abort the server sends (on the response COB-ID).
Frame encode_server_abort(std::uint8_t node, ObjectAddress address, std::uint32_t code) noexcept;

}  // namespace hapticd::drivers::canopen::cia301
