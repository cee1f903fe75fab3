#pragma once
/// \file
/// Object dictionary entry descriptions (CiA 301): data type, access and PDO
/// mappability of each object the driver or the simulated drive touches, and
/// the communication-profile objects (0x1000..0x1FFF) this subset knows.
/// The drive-profile objects are in 402/objects.hpp.

#include <cstdint>
#include <optional>
#include <string_view>

#include "drivers/canopen/301/object.hpp"

namespace hapticd::drivers::canopen::cia301 {

enum class Access : std::uint8_t { ro, wo, rw, constant };
std::string_view to_string(Access access) noexcept;
constexpr bool readable(Access a) noexcept { return a != Access::wo; }
constexpr bool writable(Access a) noexcept { return a == Access::wo || a == Access::rw; }

/// Which PDO direction may carry the object.
enum class Mappable : std::uint8_t { no, rpdo, tpdo };

struct ObjectInfo {
  ObjectAddress address;
  DataType type = DataType::unsigned32;
  Access access = Access::ro;
  Mappable mappable = Mappable::no;
  std::string_view name;
};

/// Communication-profile objects (CiA 301) and their standard names.
namespace object {
inline constexpr std::uint16_t device_type = 0x1000;
inline constexpr std::uint16_t error_register = 0x1001;
inline constexpr std::uint16_t cob_id_sync = 0x1005;
inline constexpr std::uint16_t communication_cycle_period = 0x1006;
inline constexpr std::uint16_t cob_id_emcy = 0x1014;
inline constexpr std::uint16_t consumer_heartbeat_time = 0x1016;
inline constexpr std::uint16_t producer_heartbeat_time = 0x1017;
inline constexpr std::uint16_t identity = 0x1018;  ///< 1 vendor-ID, 2 product code, 3 revision, 4 serial
inline constexpr std::uint16_t error_behavior = 0x1029;
}  // namespace object

/// Description of a communication-profile entry (0x1000..0x1FFF subset,
/// including every RPDO/TPDO communication and mapping parameter); nullopt if
/// this subset does not know it.
std::optional<ObjectInfo> find_communication_object(ObjectAddress address) noexcept;

}  // namespace hapticd::drivers::canopen::cia301
