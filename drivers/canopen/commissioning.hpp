#pragma once
/// \file
/// The commissioning SDO access (read and write any object by index and
/// sub-index) as pure rules: which data type a write takes (the object's
/// standard type when this subset knows it, else the one given), and which
/// objects are refused while the drive is enabled because they change the
/// meaning or the bound of what the cyclic exchange sends or reads, or the
/// dead-man.

#include <cstdint>
#include <optional>
#include <string>

#include "drivers/canopen/301/object.hpp"

namespace hapticd::drivers::canopen {

/// The value of one commissioning access.
struct SdoAccess {
  cia301::ObjectAddress address;
  std::uint32_t raw = 0;
  std::optional<cia301::DataType> type;  ///< known for the standard objects of this subset
  std::int64_t value = 0;                ///< raw interpreted in `type` (raw itself when unknown)
  std::string name;                      ///< the standard name, "" if unknown
  std::string note;  ///< what the write changed for hapticd (a new torque unit), "" if nothing
};

/// `raw` as read from (or written to) `address`, in `type`, else the
/// object's standard type when this subset knows it, with its name.
SdoAccess describe_access(cia301::ObjectAddress address, std::uint32_t raw,
                          std::optional<cia301::DataType> type);

/// The role of an object whose value changes the meaning or the bound of
/// what hapticd sends or reads ("motor rated torque: the scale of every
/// torque hapticd sends"); nullopt for any other. The list, with why each is
/// in it: the PDO communication and mapping parameters (0x1400-0x1BFF), the
/// SYNC (0x1005, 0x1006, 0x1007, 0x1019), the EMCY (0x1014, 0x1015), the
/// heartbeats and the dead-man (0x1016, 0x1017, 0x1029, 0x6007), restoring
/// defaults (0x1011), every manufacturer-specific object (0x2000-0x5FFF: a
/// motor constant or a current limit hapticd cannot recognise), the
/// controlword and target torque (RPDO1's), the stop reactions
/// (0x605A-0x605E), the mode (0x6060), the torque's scale, offset and
/// bounds (0x6072, 0x6073, 0x6075, 0x6076, 0x60B2, 0x60E0, 0x60E1), the
/// speed bound (0x6080), the position's and velocity's units, sign and
/// offset (0x607C, 0x607E, 0x608F-0x6096, 0x60A8, 0x60A9), and the
/// interpolation period (0x60C2).
std::optional<std::string> guarded_role(std::uint16_t index);

/// Why writing `address` is refused while enabled, naming the object's role
/// ("0x6076:00 motor rated torque: the scale of every torque hapticd sends;
/// refused while the drive is enabled, ..."); nullopt if it is not.
std::optional<std::string> refused_while_enabled(cia301::ObjectAddress address);

/// The type to write `address` with: `given` when present (checked against
/// the standard type if this subset knows one), else the standard type.
/// Throws std::invalid_argument naming what is accepted.
cia301::DataType write_type(cia301::ObjectAddress address, std::optional<cia301::DataType> given);

/// "0x6041", "6041", "0x00" -> numbers; throws std::invalid_argument naming the argument.
std::uint16_t parse_index(const std::string& text);
std::uint8_t parse_sub_index(const std::string& text);

}  // namespace hapticd::drivers::canopen
