#pragma once
/// \file
/// A simulated CiA 402 servo drive on a CANopen bus, protocol logic only:
/// frames in, frames out, time given by the caller (so tests are exact and
/// the bus loop, sim/drive_bus.hpp, is the only part that waits).
///
/// It reads and writes the wire with its own decoders, written from the
/// standards and not taken from the driver (drivers/canopen/301, 402): a
/// misreading of CiA 301 or 402 in either end shows as a failure instead of
/// passing both. wire.hpp (NMT, heartbeat, SYNC, EMCY, PDO parameters),
/// sdo_server.hpp (expedited SDO), drive_state_machine.hpp (CiA 402),
/// object_dictionary.hpp (its entries' types, access and mapping).
///
/// What it implements (CiA 301): NMT slave (boot-up, pre-operational,
/// operational, stopped, resets), SDO server (expedited), RPDO/TPDO 1-4 with
/// the standard mapping rules, SYNC consumer, heartbeat producer (0x1017)
/// and consumer (0x1016), EMCY producer, error behaviour (0x1029).
/// (CiA 402): the drive state machine from the controlword, the statusword,
/// modes 0x6060/0x6061 (cyclic synchronous torque; homing, when 0x6502 offers
/// it: homing_controller.hpp, 0x607C, 0x6098, 0x6099, 0x609A, 0x60FD), target torque 0x6071
/// per mille of 0x6076, position 0x6064 and velocity 0x606C from the plant,
/// 0x603F, and the abort connection option 0x6007 on a lost master.
///
/// Timing per SYNC (synchronous PDOs): the RPDO received before the SYNC
/// takes effect (controlword, target torque), the TPDOs sample the plant as
/// it is at the SYNC and go out, then the plant advances one period with the
/// torque now applied. So a position read from the TPDO of SYNC n-1 and a
/// torque sent before SYNC n is one period of delay, as on a real drive.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/canopen/drive_state_machine.hpp"
#include "sim/canopen/homing_controller.hpp"
#include "sim/canopen/object_dictionary.hpp"
#include "sim/canopen/wire.hpp"

namespace hapticd::drivers::canopen::sim {

using Micros = std::chrono::microseconds;

/// What the drive moves: the shared plant simulator in the bus program, a
/// plain model in tests. SI units: rad (m), rad/s (m/s), N m (N).
class DrivePlant {
 public:
  virtual ~DrivePlant() = default;
  virtual double position() const = 0;
  virtual double velocity() const = 0;
  virtual void step(double motor_force) = 0;  ///< one period
};

struct DriveSettings {
  std::uint8_t node_id = 1;
  std::uint32_t device_type = 0x00020192;  ///< 0x1000: servo drive (0x02), profile 402 (0x0192)
  std::uint32_t vendor_id = 0;             ///< 0x1018:1 (0: no CiA-assigned vendor)
  std::uint32_t product_code = 0x402;      ///< 0x1018:2
  std::uint32_t revision = 0x00010000;
  std::uint32_t serial = 1;
  std::uint32_t rated_torque_mnm = 1000;  ///< 0x6076, mN m (mN for a linear motor)
  double position_units_per_si = 16384.0 / (2.0 * 3.141592653589793);  ///< 0x6064 increments per rad (or m)
  double velocity_units_per_si = 16384.0 / (2.0 * 3.141592653589793);  ///< 0x606C units per rad/s (or m/s)
  std::uint32_t supported_modes = 1U << 9;  ///< 0x6502: cyclic synchronous torque only (| 1U << 5: homing)
  std::uint16_t producer_heartbeat_ms = 0;  ///< 0x1017 at power-on
  // Homing mode (homing_controller.hpp): the limit switches, and what the
  // velocity loop needs: the plant's period and moving mass or inertia.
  LimitSwitches limit_switches;
  double period_s = 1e-3;
  double moving_mass = 0.01;  ///< kg m^2 (kg): the velocity loop's gain is this x 2 pi x 20 Hz
};

/// Faults the drive can be told to show (each one a switch a test or the
/// bus program's command line sets).
struct EmergencyFault {
  std::uint16_t error_code = 0x2310;           ///< CiA 402: continuous over current
  std::optional<std::uint8_t> error_register;  ///< default: generic + the code's class bit
};

struct DriveCounters {
  std::uint64_t syncs = 0;
  std::uint64_t tpdos_sent = 0;
  std::uint64_t tpdos_dropped = 0;  ///< by the drop switch
  std::uint64_t rpdos_received = 0;
  std::uint64_t rpdo_length_errors = 0;
  std::uint64_t sdo_requests = 0;
  std::uint64_t sdo_aborts = 0;
  std::uint64_t emcys_sent = 0;
  std::uint64_t heartbeats_sent = 0;
  std::uint64_t heartbeat_timeouts = 0;
};

class SimulatedDrive {
 public:
  /// The plant is borrowed; it must outlive the drive.
  SimulatedDrive(const DriveSettings& settings, DrivePlant& plant);

  /// Power on (transitions 0 and 1, NMT initialisation): boot-up message,
  /// pre-operational, Switch On Disabled.
  void power_on(Micros now, std::vector<Frame>& out);
  /// One frame from the bus.
  void on_frame(const Frame& frame, Micros now, std::vector<Frame>& out);
  /// Timers: heartbeat producer and consumers. Call often (every ms or so).
  void tick(Micros now, std::vector<Frame>& out);
  /// When the next timer is due (for the bus loop's poll timeout).
  Micros next_deadline() const noexcept;

  // ---- fault switches ----
  /// Goes to fault with this EMCY (transition 13, then 14 at the next SYNC or tick).
  void inject_fault(const EmergencyFault& fault, Micros now, std::vector<Frame>& out);
  /// Stops answering: no frame is processed or sent, the plant stands still,
  /// until set_mute(false).
  void set_mute(bool mute) noexcept { mute_ = mute; }
  /// Skips the next `count` TPDO transmissions (-1: all until cleared with 0).
  void drop_tpdos(std::int64_t count) noexcept { drop_tpdos_ = count; }
  /// The next SDO request (for `address`, or any if nullopt) is answered with this abort.
  void abort_next_sdo(std::optional<Address> address, std::uint32_t code) noexcept;
  /// A write of 0x6060 is acknowledged but 0x6061 keeps the old mode.
  void refuse_mode(bool refuse) noexcept { refuse_mode_ = refuse; }
  /// The controller goes bus-off: one error frame (CAN_ERR_BUSOFF) to the
  /// bus, the 0x6007 reaction, then silence (as set_mute(true)).
  void go_bus_off(Micros now, std::vector<Frame>& out);
  /// Ends every switch (mute, drops, pending abort, mode refusal). The drive's
  /// own fault stays until a fault reset, as on a real drive; so does a
  /// position jump (an encoder that lost counts keeps its offset).
  void clear_switches() noexcept;
  /// 0x6064 jumps by `counts` increments from the next TPDO on, once: the
  /// offset stays (INTEGER32 wraps, as a drive's counter does).
  void jump_position(std::int64_t counts) noexcept { position_offset_counts_ += counts; }

  // ---- observation ----
  DriveState state() const noexcept { return state_; }
  NmtState nmt_state() const noexcept { return nmt_; }
  std::uint16_t statusword() const noexcept;
  std::uint16_t controlword() const noexcept { return controlword_; }
  std::int8_t mode_display() const noexcept;
  double applied_force() const noexcept { return applied_force_; }  ///< N m over the last step
  std::uint16_t error_code() const noexcept;
  bool muted() const noexcept { return mute_; }
  const DriveCounters& counters() const noexcept { return counters_; }
  const ObjectDictionary& dictionary() const noexcept { return od_; }
  const DriveSettings& settings() const noexcept { return settings_; }
  /// Why the drive is in fault, in words ("" when it is not).
  const std::string& fault_reason() const noexcept { return fault_reason_; }

 private:
  enum class Direction : std::uint8_t { receive, transmit };  ///< RPDO, TPDO
  /// A PDO's mapping as the dictionary holds it: entries and their byte offsets.
  struct PdoLayout {
    int count = 0;
    Address objects[8];
    std::uint8_t bytes[8] = {};
    std::uint8_t offsets[8] = {};
    std::uint8_t length = 0;  ///< bytes in all
  };
  struct RxPdoBuffer {
    bool pending = false;
    Frame frame;
  };
  struct Consumer {
    bool active = false;  ///< set by the first heartbeat (not the boot-up)
    Micros last{0};
  };

  void build_dictionary();
  void add_pdo_parameters(int number);
  void enter_nmt(NmtState state, Micros now);
  void reset_communication(Micros now, std::vector<Frame>& out);
  void on_nmt(NmtCommand command, Micros now, std::vector<Frame>& out);
  void on_sdo(const Frame& frame, std::vector<Frame>& out);
  std::uint32_t sdo_download(Address address, std::uint32_t value, std::uint8_t size);
  std::uint32_t check_pdo_write(Address address, std::uint32_t value) const;
  std::uint32_t check_mapping_write(Direction direction, int number, Address address,
                                    std::uint32_t value) const;
  std::uint32_t check_drive_write(Address address, std::uint32_t value) const;
  void after_write(Address address);
  void on_sync(std::vector<Frame>& out);
  void on_rpdo(int number, const Frame& frame, std::vector<Frame>& out);
  void apply_rpdo(int number, const Frame& frame, std::vector<Frame>& out);
  void send_tpdos(std::vector<Frame>& out);
  double torque_to_apply() const;
  /// Homing mode: the homing controller's force for this period, and the
  /// position shift once it found the home.
  double homing_force();
  std::int64_t position_counts() const;  ///< 0x6064 before the homing shift
  void on_heartbeat(const Heartbeat& hb, Micros now);
  void watch_consumers(Micros now, std::vector<Frame>& out);
  void on_controlword(std::uint16_t controlword, std::vector<Frame>& out);
  void fault(std::uint16_t code, std::uint8_t error_register, const std::string& reason,
             std::vector<Frame>& out);
  void lost_master(std::uint16_t emcy_code, const std::string& reason, std::vector<Frame>& out);
  void finish_fault_reaction();
  void refresh_process_values();
  void send_emcy(std::uint16_t code, std::uint8_t error_register, std::vector<Frame>& out);
  static std::uint16_t communication_index(Direction direction, int number) noexcept;
  static std::uint16_t mapping_index(Direction direction, int number) noexcept;
  std::optional<PdoLayout> layout(Direction direction, int number) const;
  PdoCobId cob_id(Direction direction, int number) const;
  ConsumerEntry consumer(int i) const;

  DriveSettings settings_;
  DrivePlant& plant_;
  ObjectDictionary od_;
  NmtState nmt_ = NmtState::boot_up;
  DriveState state_ = DriveState::not_ready_to_switch_on;
  std::uint16_t controlword_ = 0;
  double applied_force_ = 0.0;
  std::string fault_reason_;
  RxPdoBuffer rpdo_[4];
  std::uint8_t tpdo_sync_count_[4] = {};
  std::vector<Consumer> consumers_;  ///< one per 0x1016 sub-index 1..n
  Micros next_heartbeat_{0};
  bool powered_ = false;

  bool mute_ = false;
  std::int64_t drop_tpdos_ = 0;
  bool abort_pending_ = false;
  std::optional<Address> abort_address_;
  std::uint32_t abort_code_ = 0;
  bool refuse_mode_ = false;
  std::int64_t position_offset_counts_ = 0;  ///< added to 0x6064 (position-jump)
  HomingController homing_;
  std::int64_t home_shift_counts_ = 0;  ///< added to 0x6064 by a homing, until power-on or NMT reset node

  DriveCounters counters_;
};

/// The error register an EMCY of this code sets: generic, plus current /
/// voltage / temperature / communication by the code's class.
std::uint8_t error_register_for(std::uint16_t code) noexcept;

}  // namespace hapticd::drivers::canopen::sim
