#pragma once
/// \file
/// The per-period frame exchange with the drive (cyclic synchronous torque),
/// as pure logic: frames in, frames out, no system call, no allocation, no
/// text. The RT loop runs it (read: drain the socket into on_frame(), then
/// begin_period(); write: end_period() and send what it returns); enable()
/// and the tests run the same code.
///
/// Per period, without waiting: the newest TPDOs give the position (sampled
/// by the drive at the previous SYNC); the scene's force goes out in the
/// RPDO, then the SYNC, at which the drive applies it. So the device adds
/// one period of delay. A TPDO missing for a period is counted (the last
/// position stands); missing for tpdo_timeout_periods, it is a fault.
///
/// Faults latch with the drive's own reason until request_fault_reset():
/// an EMCY (code != 0), the statusword in Fault, the drive leaving
/// Operation Enabled or NMT operational, TPDOs missing, the drive's heartbeat
/// lost, a bus error frame (bus-off ...), the link lost; an EMCY or heartbeat
/// that breaks CiA 301 (its length, an undefined NMT state), a message on the
/// socket that is no can_frame, the drive's boot-up (it restarted), and the
/// torque unit 0x6076 changing under hapticd. A malformed frame is never
/// dropped quietly: the driver cannot tell what the drive meant by it. While latched the
/// torque is 0 and the halt bit set. The reset drives the CiA 402 fault
/// reset (bit 7 low, then high), NMT start if the drive left operational,
/// and the enable sequence, until the drive is back in Operation Enabled.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "drivers/canopen/301/emcy.hpp"
#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/pdo.hpp"
#include "drivers/canopen/402/state_machine.hpp"
#include "drivers/canopen/can_error.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/drive_setup.hpp"

namespace hapticd::drivers::canopen {

struct CyclicSettings {
  std::uint8_t node = 1;
  std::uint8_t master_node = 127;
  CyclicMapping mapping;
  Scaling scaling;
  std::uint32_t tpdo_timeout_periods = 3;
  std::uint32_t heartbeat_every_periods = 20;           ///< hapticd's heartbeat producer, in periods
  std::uint32_t drive_heartbeat_timeout_periods = 100;  ///< the drive's heartbeat, watched; 0: not watched
  std::uint32_t reset_timeout_periods = 1000;  ///< a fault reset that has not enabled the drive by then fails
};

enum class FaultKind : std::uint8_t {
  none,
  emcy,                 ///< the drive sent an EMCY (emcy)
  drive_fault,          ///< the statusword shows Fault / Fault Reaction Active (statusword)
  left_enabled,         ///< the drive left Operation Enabled on its own (statusword)
  tpdo_timeout,         ///< no TPDO1 for `periods`
  heartbeat_lost,       ///< no heartbeat from the drive for `periods`
  left_operational,     ///< the drive's heartbeat shows another NMT state (nmt)
  bus_error,            ///< an error frame (bus)
  link_lost,            ///< the socket failed (link_errno, link_closed)
  reset_failed,         ///< the fault reset did not bring the drive back (statusword)
  malformed_frame,      ///< an EMCY or heartbeat from the drive that breaks CiA 301 (frame, malformed)
  malformed_message,    ///< a message on the socket that is no can_frame (message)
  drive_restarted,      ///< the drive's boot-up: its setup may be lost (not cleared by a fault reset)
  torque_unit_changed,  ///< 0x6076 is not what the scale was built on (rated_before, rated_after)
};

/// What broke CiA 301 in a frame from the drive.
enum class MalformedFrame : std::uint8_t {
  none,
  emcy_length,       ///< an EMCY of other than 8 bytes (CiA 301 7.2.7.3.1)
  heartbeat_length,  ///< a heartbeat of other than 1 byte
  heartbeat_state,   ///< a heartbeat whose state is no NMT state (0x00, 0x04, 0x05, 0x7F)
};

struct FaultRecord {
  FaultKind kind = FaultKind::none;
  cia301::Emergency emcy;
  std::uint16_t statusword = 0;
  std::uint32_t periods = 0;
  cia301::NmtState nmt = cia301::NmtState::operational;
  BusError bus;
  int link_errno = 0;
  bool link_closed = false;
  MalformedFrame malformed = MalformedFrame::none;
  cia301::Frame frame;  ///< the malformed frame as it arrived
  MalformedMessage message;
  std::uint32_t rated_before = 0, rated_after = 0;  ///< 0x6076, mN m
  std::uint64_t period = 0;                         ///< the period it latched in
};
/// The fault in words, the drive's own where it gave any ("EMCY 0x2310: ...").
std::string describe(const FaultRecord& fault, const CyclicSettings& settings);

struct CyclicCounters {
  std::uint64_t periods = 0;
  std::uint64_t tpdos = 0;
  std::uint64_t late_tpdos = 0;   ///< periods that started without a fresh TPDO1
  std::uint64_t short_tpdos = 0;  ///< TPDOs shorter than the mapping (ignored)
  std::uint64_t emcys = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t drive_heartbeats = 0;
  std::uint64_t tx_dropped = 0;          ///< frames the socket refused (TX queue full)
  std::uint64_t malformed_frames = 0;    ///< EMCYs and heartbeats that break CiA 301 (each a fault)
  std::uint64_t malformed_messages = 0;  ///< socket messages that are no can_frame (each a fault)
};

/// What the drive reported for this period.
struct CycleReading {
  bool valid = false;     ///< a position has been received (fresh or held)
  bool fresh = false;     ///< from a TPDO that arrived since the last period
  double position = 0.0;  ///< rad or m at the output
  double velocity = 0.0;  ///< rad/s or m/s (TPDO2), 0 without it
  std::uint16_t statusword = 0;
};

enum class FrameUse : std::uint8_t { cyclic, sdo_response, ignored };

class CyclicExchange {
 public:
  explicit CyclicExchange(const CyclicSettings& settings);

  // ---- RT ----
  FrameUse on_frame(const cia301::Frame& frame) noexcept;
  void on_link_lost(int error, bool closed) noexcept;
  /// A message that is no can_frame arrived (CanSocket::receive said malformed).
  void on_malformed_message(const MalformedMessage& message) noexcept;
  /// The torque unit: output N m (N) per 0x6071 unit. While the drive is
  /// enabled only after a fault latched (on_torque_unit_changed).
  void set_force_per_permille(double force_per_permille) noexcept {
    force_per_permille_ = force_per_permille;
  }
  double force_per_permille() const noexcept { return force_per_permille_; }
  /// 0x6076 read back differs from the one the scale was built on: a fault.
  void on_torque_unit_changed(std::uint32_t before_mnm, std::uint32_t after_mnm) noexcept;
  void on_frame_dropped() noexcept { ++counters_.tx_dropped; }
  CycleReading begin_period() noexcept;
  /// The frames of this period into `out`: RPDO1, SYNC, then the heartbeat
  /// when due and an NMT start during a reset. Returns how many. A
  /// non-finite force is no valid command: torque 0 and halt.
  std::size_t end_period(double force, std::span<cia301::Frame, 4> out) noexcept;

  /// Enabled: the controlwords lead the drive to Operation Enabled and keep it
  /// there; disabled: Disable Voltage. Either way the torque is 0 until enabled.
  void set_enabled(bool enabled) noexcept;
  /// Homing mode (before the loop): while set, a period whose command flows
  /// also carries controlword bit 4, homing operation start (CiA 402).
  void set_homing_start(bool start) noexcept { homing_start_ = start; }
  void request_fault_reset() noexcept;

  // ---- observation (the same thread, or copied out by the owner) ----
  bool faulted() const noexcept { return fault_.kind != FaultKind::none; }
  bool has_position() const noexcept { return have_position_; }
  const FaultRecord& fault() const noexcept { return fault_; }
  bool resetting() const noexcept { return resetting_; }
  /// The drive is in Operation Enabled, no fault latched, no reset running.
  bool operational() const noexcept;
  std::optional<cia402::DriveState> drive_state() const noexcept;
  std::uint16_t statusword() const noexcept { return statusword_; }  ///< the newest TPDO1's
  std::uint16_t last_controlword() const noexcept { return controlword_; }
  std::int16_t last_torque_permille() const noexcept { return torque_; }
  const CyclicCounters& counters() const noexcept { return counters_; }
  const CyclicSettings& settings() const noexcept { return settings_; }

 private:
  void latch(FaultRecord record) noexcept;
  void on_tpdo_position(const cia301::Frame& frame) noexcept;
  void on_tpdo_velocity(const cia301::Frame& frame) noexcept;
  void check_statusword() noexcept;
  void on_emergency(const cia301::Frame& frame) noexcept;
  void on_drive_heartbeat(const cia301::Frame& frame) noexcept;
  void latch_malformed(MalformedFrame what, const cia301::Frame& frame) noexcept;

  CyclicSettings settings_;
  double force_per_permille_ = 0.0;  ///< settings_.scaling's, until set_force_per_permille()
  FaultRecord fault_;
  CyclicCounters counters_;
  bool enabled_ = false;
  bool homing_start_ = false;
  bool resetting_ = false;
  bool was_operation_enabled_ = false;
  std::uint64_t reset_started_ = 0;

  // Newest TPDO data.
  bool have_position_ = false;
  bool fresh_position_ = false;
  std::uint16_t statusword_ = 0;
  std::int32_t last_raw_position_ = 0;
  std::int64_t position_counts_ = 0;  ///< unwrapped across INTEGER32 overflow
  double velocity_ = 0.0;
  std::uint32_t missing_periods_ = 0;

  // The drive's heartbeat.
  bool drive_heartbeat_seen_ = false;
  std::uint32_t periods_since_heartbeat_ = 0;
  cia301::NmtState drive_nmt_ = cia301::NmtState::operational;

  // What went out last.
  std::uint16_t controlword_ = 0;
  std::int16_t torque_ = 0;
  std::uint32_t periods_to_heartbeat_ = 0;
};

}  // namespace hapticd::drivers::canopen
