#pragma once
/// \file
/// Typed parameters of the usb-hid driver (README.md "Configuration"):
/// which board, how its counts and commands become SI, the report layout,
/// the dead-man and timeouts, the event handling, and the device model the
/// stability gate uses. Non-RT.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/parameter.hpp"
#include "drivers/usb_hid/report_codec.hpp"
#include "drivers/usb_hid/usb_transport.hpp"

namespace hapticd::drivers::usb_hid {

/// One axis of a board with several: its encoder and amplifier scales and
/// the mass and damping the stability gate judges it with.
struct UsbHidAxis {
  double counts_per_unit = 16384.0;  ///< counts per metre (a stage's axes are linear)
  double command_full_scale = 1.0;   ///< N at the largest command
  double mass = 0.01;                ///< kg
  double damping = 0.0;              ///< N s/m
};

struct UsbHidConfig {
  UsbSelector selector;  ///< vendor_id, product_id (required), serial, path, interface, endpoints
  Motion motion = Motion::rotary;
  /// Encoder counts per revolution (rotary) or per metre (linear), after any gearing.
  double counts_per_unit = 16384.0;
  /// Force or torque at the largest command (N m or N): the amplifier's scale.
  double command_full_scale = 1.0;
  bool inverted = false;  ///< direction = inverted: both the count and the command change sign
  ReportLayout layout;
  int deadman_periods = 3;  ///< the board zeroes its output after this many periods without a new OUT report
  int timeout_periods = 5;  ///< the host latches a fault after this many periods without a new IN report
  int in_transfers = 2;
  int out_transfers = 4;
  EventHandling events = EventHandling::loop;
  // The device model for the stability gate (the board cannot know it).
  double mass = 0.01;      ///< kg m^2 (rotary) or kg (linear)
  double damping = 0.0;    ///< N m s/rad or N s/m
  int delay_periods = -1;  ///< -1: from the endpoints' polling intervals (link_delay_periods)
  /// A board with several axes (`axes` = 2 to 6, as many as layout.axes()):
  /// each axis' scales and model. Empty for one axis, which the fields above
  /// describe.
  std::vector<UsbHidAxis> axes;

  /// The axes the board carries: 1, or axes.size().
  std::size_t axis_count() const noexcept { return axes.empty() ? 1 : axes.size(); }
  /// rad or m per count (2 pi / counts or 1 / counts), with the direction's sign.
  double position_per_count() const noexcept;
  /// Axis `k`'s (0-based) m per count; axis 0 of one axis is position_per_count().
  double position_per_count(std::size_t k) const noexcept;
  /// Axis `k`'s force at the largest command.
  double command_full_scale_of(std::size_t k) const noexcept {
    return axes.empty() ? command_full_scale : axes[k].command_full_scale;
  }
  /// The OUT report's dead-man field for this period, in microseconds.
  std::uint32_t deadman_us(double period_s) const noexcept;
  /// Everything that can be checked without the board, at this period.
  /// Throws DeviceError naming the key to blame.
  void validate(double period_s) const;
};

/// "0x1209" or "4617" -> 0x1209; throws std::invalid_argument.
std::uint16_t parse_usb_id(std::string_view text);

/// "auto" -> 0, "0x81" -> 0x81: an interrupt endpoint address of the given
/// direction (IN: 0x81..0x8f, OUT: 0x01..0x0f); throws std::invalid_argument
/// saying what is accepted.
std::uint8_t parse_endpoint_address(std::string_view text, bool in);

/// The typed values of [device.usb-hid] as a config, every key converted
/// once (usb_hid_driver.cpp, beside the table that describes them). Throws
/// ParameterError naming the key.
UsbHidConfig usb_hid_config_from(const DriverParameters& parameters);

}  // namespace hapticd::drivers::usb_hid
