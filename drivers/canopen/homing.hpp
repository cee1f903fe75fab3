#pragma once
/// \file
/// CiA 402 homing before the loop ([device.canopen] homing = "cia402";
/// README.md, "Homing"): the drive searches its home by the configured
/// method in homing mode (0x6060 = 6), then goes back to cyclic synchronous
/// torque (10) for the loop. Pure logic above the codecs, as drive_setup:
///   prepare_homing()  0x6098 method, 0x607C home offset, 0x6099:1/2 speeds
///                     and 0x609A acceleration by SDO (each refusal naming
///                     its config key), then 0x6060 = 6 confirmed in 0x6061;
///   HomingSequence    once per period from the TPDO's statusword: enable
///                     (the usual controlwords), then controlword bit 4 to
///                     start, until the statusword says completed (bits 12
///                     and 10), an error (bit 13), or the time is up.
/// The device runs the periods (canopen_device.cpp) and switches back to mode 10.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivers/canopen/402/homing.hpp"
#include "drivers/canopen/402/state_machine.hpp"
#include "drivers/canopen/sdo_client.hpp"

namespace hapticd::drivers::canopen {

/// The homing objects in the drive's units (canopen_config.cpp converts the SI keys).
struct HomingSettings {
  std::int8_t method = 37;              ///< 0x6098
  std::int32_t home_offset_counts = 0;  ///< 0x607C
  /// 0x6099:1, 0x6099:2, 0x609A in velocity units (per second); nullopt: the drive's own.
  std::optional<std::uint32_t> speed_switch, speed_zero, acceleration;
  double timeout_s = 20.0;
};

/// Writes the homing objects and selects homing mode. Throws SetupError
/// naming the config key (homing_method, home_offset, homing_speed_switch,
/// homing_speed_zero, homing_acceleration; homing for a drive without the
/// mode). An object the drive lacks is fatal only where the method needs it;
/// otherwise noted in `notes`.
void prepare_homing(SdoClient& sdo, const HomingSettings& settings, std::vector<std::string>& notes);

enum class HomingPhase : std::uint8_t {
  enabling,  ///< the controlwords towards Operation Enabled
  starting,  ///< bit 4 sent; waiting for TPDOs sampled after it
  homing,    ///< the statusword's homing bits are the drive's answer
  completed,
  failed,
};

enum class HomingFailure : std::uint8_t {
  none,
  not_enabled,      ///< the drive did not reach Operation Enabled in time
  drive_fault,      ///< the exchange latched a fault (EMCY, statusword, missing TPDO ...)
  homing_error,     ///< statusword bit 13
  interrupted,      ///< the drive said "interrupted" after it had started
  reserved_status,  ///< bits 13 and 12 together
  timed_out,        ///< homing_timeout passed without completion
};

/// What the exchange saw this period (after its begin_period()).
struct HomingObservation {
  bool operational = false;  ///< in Operation Enabled, no fault latched
  bool faulted = false;      ///< the exchange latched a fault
  std::uint16_t statusword = 0;
  std::uint64_t tpdos = 0;  ///< TPDO1s received so far
};

/// The homing run, one step per period; pure and allocation-free.
class HomingSequence {
 public:
  /// Limits in periods: to reach Operation Enabled, and from the start to completion.
  HomingSequence(std::uint64_t enable_periods, std::uint64_t homing_periods) noexcept
      : enable_periods_(enable_periods), homing_periods_(homing_periods) {}

  /// One period's observation; the phase after it.
  HomingPhase step(const HomingObservation& seen) noexcept;
  /// Controlword bit 4 in this period's RPDO: from the start until the end.
  bool start_bit() const noexcept { return phase_ == HomingPhase::starting || phase_ == HomingPhase::homing; }

  HomingPhase phase() const noexcept { return phase_; }
  HomingFailure failure() const noexcept { return failure_; }
  cia402::HomingStatus last_status() const noexcept { return status_; }
  std::uint16_t last_statusword() const noexcept { return statusword_; }
  /// Periods from the first with bit 4 to the one that saw completion (or the end).
  std::uint64_t homing_periods() const noexcept { return homing_; }
  bool done() const noexcept { return phase_ == HomingPhase::completed || phase_ == HomingPhase::failed; }

 private:
  void fail(HomingFailure why) noexcept {
    failure_ = why;
    phase_ = HomingPhase::failed;
  }
  void judge(const HomingObservation& seen) noexcept;

  std::uint64_t enable_periods_;
  std::uint64_t homing_periods_;
  HomingPhase phase_ = HomingPhase::enabling;
  HomingFailure failure_ = HomingFailure::none;
  cia402::HomingStatus status_ = cia402::HomingStatus::interrupted_or_not_started;
  std::uint16_t statusword_ = 0;
  std::uint64_t periods_ = 0;  ///< in the current phase
  std::uint64_t homing_ = 0;
  std::uint64_t tpdos_at_start_ = 0;
  bool progress_seen_ = false;
};

/// TPDOs that must arrive after the start before the statusword counts:
/// the first may be a late answer to a SYNC sent before it.
inline constexpr std::uint64_t tpdos_after_start = 2;

/// Why it failed, in words, with the config key to blame (homing_method for
/// the drive's homing error, homing_timeout, else homing: the homing asked for).
struct HomingVerdict {
  std::string text;
  std::string key;
};
HomingVerdict describe(const HomingSequence& sequence, std::uint8_t node, std::int8_t method,
                       double period_s);

}  // namespace hapticd::drivers::canopen
