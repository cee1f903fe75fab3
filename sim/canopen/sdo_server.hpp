#pragma once
/// \file
/// The simulated drive's SDO server, expedited transfers only, written from
/// CiA 301 7.2.4.3 (not from the driver's codec): every SDO frame has 8
/// bytes, byte 0 the command specifier, bytes 1-2 the index (little-endian),
/// byte 3 the sub-index, bytes 4-7 the data or the abort code.
///
///   byte 0 of a request:  ccs (bits 7..5) | x | n (bits 3..2) | e (bit 1) | s (bit 0)
///     ccs 1 initiate download: e = 1 expedited, s = 1 size indicated, then
///           4 - n data bytes; e = 1, s = 0: unspecified size; e = 0: segmented
///     ccs 2 initiate upload (the rest of byte 0 zero)
///     ccs 4 abort transfer (the client's)
///     ccs 0, 3, 5, 6: segments and block transfers (not served: abort 0x05040001)
///   byte 0 of a response: scs (bits 7..5)
///     scs 2 initiate upload, expedited: n, e = 1, s = 1
///     scs 3 initiate download
///     scs 4 abort, the code in bytes 4..7

#include <cstdint>
#include <optional>
#include <string_view>

#include "sim/canopen/wire.hpp"

namespace hapticd::drivers::canopen::sim {

struct SdoRequest {
  enum class Kind : std::uint8_t {
    upload,              ///< ccs 2: read `address`
    expedited_download,  ///< ccs 1, e = 1: write `data` (`size` bytes, 0 = not indicated)
    segmented_or_block,  ///< a transfer of more than 4 bytes: not served
    client_abort,        ///< ccs 4: the client gives up
    unknown,             ///< ccs 7: no such command
  };
  Kind kind = Kind::unknown;
  Address address;
  std::uint32_t data = 0;
  std::uint8_t size = 0;
};
/// A request to the server (the caller checked the CAN-ID); nullopt unless 8 bytes.
std::optional<SdoRequest> parse_sdo_request(const Frame& frame) noexcept;

/// The server's answers, on CAN-ID 0x580 + node.
Frame upload_response(std::uint8_t node, Address address, std::uint32_t value, std::uint8_t size) noexcept;
Frame download_response(std::uint8_t node, Address address) noexcept;
Frame abort_response(std::uint8_t node, Address address, std::uint32_t code) noexcept;

/// The abort codes this server gives (CiA 301 Table 22).
namespace abort_code {
inline constexpr std::uint32_t unknown_command = 0x05040001;   ///< command specifier not valid or unknown
inline constexpr std::uint32_t write_only = 0x06010001;        ///< attempt to read a write-only object
inline constexpr std::uint32_t read_only = 0x06010002;         ///< attempt to write a read-only object
inline constexpr std::uint32_t no_object = 0x06020000;         ///< object does not exist
inline constexpr std::uint32_t not_mappable = 0x06040041;      ///< object cannot be mapped to the PDO
inline constexpr std::uint32_t mapping_too_long = 0x06040042;  ///< mapped objects exceed the PDO length
inline constexpr std::uint32_t parameter_incompatible = 0x06040043;
inline constexpr std::uint32_t length_too_high = 0x06070012;  ///< data type does not match, length too high
inline constexpr std::uint32_t length_too_low = 0x06070013;   ///< data type does not match, length too low
inline constexpr std::uint32_t no_sub_index = 0x06090011;     ///< sub-index does not exist
inline constexpr std::uint32_t invalid_value = 0x06090030;    ///< invalid value for parameter (download only)
inline constexpr std::uint32_t wrong_state = 0x08000022;      ///< data cannot be stored: present device state
}  // namespace abort_code

/// The words of an abort code (any of CiA 301's; "not a CiA 301 abort code" otherwise).
std::string_view abort_words(std::uint32_t code) noexcept;

}  // namespace hapticd::drivers::canopen::sim
