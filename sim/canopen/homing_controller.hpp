#pragma once
/// \file
/// The simulated drive's homing mode (0x6060 = 6), written from CiA 402-2
/// "Homing mode" for this drive, not taken from the driver's codec
/// (drivers/canopen/402/homing.hpp): what a drive does with controlword bit 4
/// and which statusword bits it shows.
///
///   controlword bit 4: 0 -> 1 starts homing, 1 -> 0 interrupts it; bit 8
///   (halt) interrupts it too.
///   statusword bit 13 error, bit 12 attained, bit 10 target reached:
///     0 0 0 in progress; 0 0 1 interrupted or not started; 0 1 0 attained,
///     target not reached (stopping); 0 1 1 completed; 1 0 x error
///     (x: velocity 0). Bit 12 stays set after a completed homing until the
///     next start, as many drives keep it.
///
/// Methods this drive has:
///   35, 37  on the current position: the home is where the drive stands;
///   17      on the negative limit switch: towards it at the switch search
///           speed (0x6099:1) until it is active, back at the zero search
///           speed (0x6099:2) until it is not; the home is that edge;
///   18      the same on the positive limit switch.
/// Motion follows a velocity reference ramped at 0x609A, by a velocity loop
/// on the plant's measured velocity, within the drive's torque limit. Once
/// the home is found the drive stops; at the home, 0x6064 reads -0x607C
/// (CiA 402: the zero lies the home offset past the home position).
/// A switch hit in the wrong direction (the other side's) is a homing error.

#include <cstdint>
#include <optional>

namespace hapticd::drivers::canopen::sim {

/// What the drive's objects say for the homing (its own units, SI where noted).
struct HomingObjects {
  std::int8_t method = 0;     ///< 0x6098
  double speed_switch = 0.0;  ///< 0x6099:1, in m/s or rad/s
  double speed_zero = 0.0;    ///< 0x6099:2, in m/s or rad/s
  double acceleration = 0.0;  ///< 0x609A, in m/s^2 or rad/s^2
  double max_force = 0.0;     ///< the torque limit, N m or N
};

/// Where the limit switches are (SI): the negative one is active at or
/// below `negative`, the positive one at or above `positive`.
struct LimitSwitches {
  std::optional<double> negative, positive;
};

class HomingController {
 public:
  /// `velocity_gain`: N m s/rad (N s/m) of the velocity loop.
  HomingController(LimitSwitches switches = {}, double velocity_gain = 0.0)
      : switches_(switches), gain_(velocity_gain) {}

  /// The methods this drive runs, with these switches (0x6098 writes are checked against it).
  bool has_method(std::int8_t method) const noexcept;
  /// Controlword bits 4 (operation start) and 8 (halt), in homing mode and
  /// Operation Enabled: starts on the 0 -> 1 edge of bit 4, interrupts on
  /// its fall or on halt.
  void on_controlword(std::uint16_t previous, std::uint16_t controlword, double position) noexcept;
  /// The drive left homing mode or Operation Enabled.
  void interrupt() noexcept;
  /// One SYNC: the force for the coming period, from the position and
  /// velocity sampled at it.
  double step(double position, double velocity, const HomingObjects& objects, double period_s) noexcept;
  /// Statusword bits 10, 12, 13.
  std::uint16_t status_bits(double velocity) const noexcept;
  double gain() const noexcept { return gain_; }
  /// The home found (SI, the plant's position) since it was last taken.
  std::optional<double> take_home() noexcept;

  /// Digital inputs 0x60FD: bit 0 negative limit switch, bit 1 positive.
  std::uint32_t digital_inputs(double position) const noexcept;

 private:
  enum class Stage : std::uint8_t { idle, starting, searching, leaving, stopping, done, error };
  bool negative_active(double position) const noexcept;
  bool positive_active(double position) const noexcept;
  void found_home(double position) noexcept;
  double run_velocity(double velocity, const HomingObjects& o, double period_s) noexcept;
  /// The method in 0x6098 at the first SYNC after the start.
  void begin(double position, const HomingObjects& o) noexcept;
  /// The switch search: the edges of the method's switch.
  void follow_switch(double position) noexcept;

  LimitSwitches switches_;
  double gain_;
  Stage stage_ = Stage::idle;
  bool attained_before_ = false;  ///< bit 12 kept after a completed homing
  bool started_ = false;          ///< started since power-on (idle after it: interrupted, braking)
  std::int8_t method_ = 0;
  double speed_zero_ = 0.0;
  double reference_ = 0.0;  ///< the velocity reference, ramped
  double target_ = 0.0;     ///< where the reference ramps to
  std::optional<double> home_;
};

}  // namespace hapticd::drivers::canopen::sim
