#include "drivers/canopen/402/objects.hpp"

#include <cmath>

namespace hapticd::drivers::canopen::cia402 {

using cia301::Access;
using cia301::DataType;
using cia301::Mappable;
using cia301::ObjectAddress;
using cia301::ObjectInfo;

std::string_view to_string(Mode mode) noexcept { return describe_mode(static_cast<std::int8_t>(mode)); }

std::string_view describe_mode(std::int8_t value) noexcept {
  switch (value) {
    case 0:
      return "no mode";
    case 1:
      return "profile position";
    case 2:
      return "velocity";
    case 3:
      return "profile velocity";
    case 4:
      return "profile torque";
    case 6:
      return "homing";
    case 7:
      return "interpolated position";
    case 8:
      return "cyclic synchronous position";
    case 9:
      return "cyclic synchronous velocity";
    case 10:
      return "cyclic synchronous torque";
    default:
      return value < 0 ? "manufacturer-specific mode" : "reserved mode";
  }
}

std::optional<unsigned> supported_mode_bit(Mode mode) noexcept {
  switch (mode) {
    case Mode::profile_position:
      return 0;
    case Mode::velocity:
      return 1;
    case Mode::profile_velocity:
      return 2;
    case Mode::profile_torque:
      return 3;
    case Mode::homing:
      return 5;
    case Mode::interpolated_position:
      return 6;
    case Mode::cyclic_synchronous_position:
      return 7;
    case Mode::cyclic_synchronous_velocity:
      return 8;
    case Mode::cyclic_synchronous_torque:
      return 9;
    case Mode::none:
      return std::nullopt;
  }
  return std::nullopt;
}

std::optional<InterpolationPeriod> encode_interpolation_period(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) return std::nullopt;
  const double us = period_s * 1e6;
  const double whole = std::round(us);
  if (whole < 1.0 || std::abs(us - whole) > 1e-6 * whole) return std::nullopt;
  // value * 10^(exponent) with value <= 255, largest exponent first (1 ms -> 1 x 10^-3).
  for (int exponent = 2; exponent >= -6; --exponent) {
    const double scale = std::pow(10.0, exponent + 6);  // in us
    const double value = whole / scale;
    if (value >= 1.0 && value <= 255.0 && std::abs(value - std::round(value)) < 1e-9)
      return InterpolationPeriod{static_cast<std::uint8_t>(std::lround(value)),
                                 static_cast<std::int8_t>(exponent)};
  }
  return std::nullopt;
}

double decode_interpolation_period(InterpolationPeriod p) noexcept {
  return p.value * std::pow(10.0, p.exponent);
}

namespace {

constexpr ObjectInfo drive_objects[] = {
    {{object::abort_connection_option, 0},
     DataType::integer16,
     Access::rw,
     Mappable::no,
     "abort connection option code"},
    {{object::error_code, 0}, DataType::unsigned16, Access::ro, Mappable::tpdo, "error code"},
    {{object::controlword, 0}, DataType::unsigned16, Access::rw, Mappable::rpdo, "controlword"},
    {{object::statusword, 0}, DataType::unsigned16, Access::ro, Mappable::tpdo, "statusword"},
    {{object::quick_stop_option, 0}, DataType::integer16, Access::rw, Mappable::no, "quick stop option code"},
    {{object::modes_of_operation, 0}, DataType::integer8, Access::rw, Mappable::rpdo, "modes of operation"},
    {{object::modes_of_operation_display, 0},
     DataType::integer8,
     Access::ro,
     Mappable::tpdo,
     "modes of operation display"},
    {{object::position_actual, 0}, DataType::integer32, Access::ro, Mappable::tpdo, "position actual value"},
    {{object::velocity_actual, 0}, DataType::integer32, Access::ro, Mappable::tpdo, "velocity actual value"},
    {{object::target_torque, 0}, DataType::integer16, Access::rw, Mappable::rpdo, "target torque"},
    {{object::max_torque, 0}, DataType::unsigned16, Access::rw, Mappable::rpdo, "max torque"},
    {{object::rated_torque, 0}, DataType::unsigned32, Access::rw, Mappable::no, "motor rated torque (mN m)"},
    {{object::torque_actual, 0}, DataType::integer16, Access::ro, Mappable::tpdo, "torque actual value"},
    {{object::interpolation_time_period, 0},
     DataType::unsigned8,
     Access::ro,
     Mappable::no,
     "interpolation time period: highest sub-index"},
    {{object::interpolation_time_period, 1},
     DataType::unsigned8,
     Access::rw,
     Mappable::no,
     "interpolation time period value"},
    {{object::interpolation_time_period, 2},
     DataType::integer8,
     Access::rw,
     Mappable::no,
     "interpolation time index"},
    {{object::supported_drive_modes, 0},
     DataType::unsigned32,
     Access::ro,
     Mappable::no,
     "supported drive modes"},
};

}  // namespace

std::optional<ObjectInfo> find_drive_object(ObjectAddress address) noexcept {
  for (const ObjectInfo& info : drive_objects)
    if (info.address == address) return info;
  return std::nullopt;
}

std::optional<ObjectInfo> find_standard_object(ObjectAddress address) noexcept {
  if (auto info = cia301::find_communication_object(address)) return info;
  return find_drive_object(address);
}

}  // namespace hapticd::drivers::canopen::cia402
