#pragma once
/// \file
/// The commissioning SDO access (read and write any object by index and
/// sub-index) as pure rules: which data type a write takes (the object's
/// standard type when this subset knows it, else the one given), and which
/// objects are refused while the drive is enabled because the cyclic
/// exchange or the dead-man depends on them.

#include <cstdint>
#include <optional>
#include <string>

#include "drivers/canopen/301/object.hpp"

namespace hapticd::drivers::canopen {

/// Why writing `address` is refused while enabled; nullopt if it is not.
/// Refused: PDO communication and mapping parameters (0x1400-0x1BFF), the
/// mode (0x6060), the controlword (0x6040, owned by RPDO1), the
/// interpolation period (0x60C2), SYNC and heartbeat settings (0x1005,
/// 0x1006, 0x1016, 0x1017), the abort connection option (0x6007).
std::optional<std::string> refused_while_enabled(cia301::ObjectAddress address);

/// The type to write `address` with: `given` when present (checked against
/// the standard type if this subset knows one), else the standard type.
/// Throws std::invalid_argument naming what is accepted.
cia301::DataType write_type(cia301::ObjectAddress address, std::optional<cia301::DataType> given);

/// "0x6041", "6041", "0x00" -> numbers; throws std::invalid_argument naming the argument.
std::uint16_t parse_index(const std::string& text);
std::uint8_t parse_sub_index(const std::string& text);

}  // namespace hapticd::drivers::canopen
