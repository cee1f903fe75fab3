#pragma once
/// \file
/// The simulated amplifier's protocol logic: its own register map
/// (amplifier_registers.hpp) in front of a plant. Pure: no system calls; the
/// server (amplifier_server.hpp) receives each request with libmodbus, asks
/// on_request() what to do, and answers with build_reply() or an exception
/// reply, framed by amplifier_wire.hpp. It reads the request with its own
/// decoder (amplifier_wire.hpp), written from the Modbus Application
/// Protocol Specification V1.1b3, not with the driver's codec.
///
/// What it does with a request addressed to it, in order:
///  1. an injected failure, if one is pending (an exception reply; silence,
///     as if the request were lost on the line; a reply with a wrong CRC,
///     after applying the request; a dropped connection; a late reply);
///  2. the request's own exceptions (AP 6.x state diagrams): 01 for a
///     function it does not serve (fc 23 too, on an amplifier set without
///     it), 03 for a quantity, byte count or coil value out of the spec, 02
///     for an address outside its tables; such a request applies nothing;
///  3. the writes (AP 6.17: fc 23 writes before it reads): the torque
///     command, the watchdog (a nonzero value arms it for that many ms of
///     its clock, 0 disarms; every write of it restarts it), the reset
///     register (1 clears the fault word), the enable coil or control bit
///     (ignored while in fault);
///  4. one plant step per request that writes the torque register, BEFORE
///     its writes take effect: the plant advances one period under the
///     torque applied since the previous command (time passes between
///     two transactions), then the new command applies (only while enabled
///     and not in fault), and the reply reports the position sampled now.
///     A run is therefore the loopback run of the same plant with delay = 1;
///  5. the state registers: position and velocity from the plant, status
///     (enabled and fault bits), fault word.
/// The watchdog expires on the amplifier's clock (tick(): the server's wall
/// clock, or a test's simulated one): power stage off, torque 0, the
/// watchdog fault bit set, until a reset and a new enable.
///
/// With alive_counter_s > 0 the watchdog register is an alive counter
/// instead (the amplifiers hapticd drives with watchdog_refresh =
/// "counter"): watched while the power stage is on, a write that leaves its
/// value unchanged trips the watchdog at once, and so does no new value for
/// alive_counter_s of its clock. A value that changes by other than +1
/// (mod 2^16) is counted (alive_jumps), not tripped on.
///
/// Threads: on_request()/tick()/build_reply() from the server thread; the
/// switches and state() from any thread (atomics).

#include <atomic>
#include <cstdint>
#include <span>

#include "drivers/device_hooks.hpp"
#include "sim/modbus/amplifier_registers.hpp"
#include "sim/modbus/amplifier_wire.hpp"

namespace hapticd::drivers::modbus::sim {

/// The plant the amplifier drives (the shared plant simulator).
class AmplifierPlant {
 public:
  virtual ~AmplifierPlant() = default;
  /// Encoder position now, m or rad (quantized).
  virtual IoResult sense(double& position) noexcept = 0;
  /// Velocity now, m/s or rad/s.
  virtual double velocity() const noexcept = 0;
  /// Applies `force` over one period and advances the plant.
  virtual IoResult step(double force) noexcept = 0;
};

/// What the amplifier's owner sets (its configuration, not its wire).
struct AmplifierSettings {
  int slave_id = 1;
  double position_per_count = 0.0;  ///< rad or m per position count
  double torque_per_count = 0.001;  ///< N m or N per command count
  bool function_23 = true;          ///< false: answers fc 23 with exception 01 (illegal function)
  WordOrder32 word_order = WordOrder32::high_word_first;
  StateTable state_table = StateTable::holding;
  EnableBy enable_by = EnableBy::control_word;
  bool watchdog_any_frame = false;    ///< every valid request restarts the watchdog, not only its writes
  double alive_counter_s = 0.0;       ///< > 0: the watchdog register is an alive counter (file comment), s
  std::uint16_t register_count = 64;  ///< holding and input tables, addresses 0..register_count-1
  std::uint16_t coil_count = 16;
};

enum class Injection : std::uint8_t {
  none,
  exception,  ///< the next requests get an exception reply (code given), nothing applied
  timeout,    ///< the next requests are lost: nothing applied, no reply
  crc_error,  ///< the next requests are applied, their replies carry a wrong CRC (RTU)
  drop,       ///< the connection is closed on the next request (TCP), nothing applied
  late,       ///< the next requests are applied and answered after a delay (a slow amplifier)
};

/// What the server does with one request.
struct Decision {
  enum class Kind : std::uint8_t { reply, exception, silence, corrupt_crc, drop } kind = Kind::reply;
  std::uint8_t exception_code = 0;
  int delay_ms = 0;  ///< wait this long before replying
};

/// A consistent-enough view for tests and the devsim status line.
struct AmplifierState {
  bool enabled = false;
  bool watchdog_armed = false;
  std::uint16_t fault = 0;
  double applied_torque = 0.0;  ///< N m or N applied now (over the coming step)
  std::int16_t torque_counts = 0;
  std::uint64_t steps = 0;
  std::uint64_t requests = 0;
  std::uint64_t watchdog_trips = 0;
  std::uint64_t resets = 0;
  /// At the last watchdog trip: wall time since the last refresh, s (what
  /// the amplifier saw of the silence; >= the watchdog time by design).
  double trip_silence_s = 0.0;
  std::uint16_t watchdog_register = 0;  ///< the value last written to it
  std::uint64_t alive_jumps = 0;        ///< alive counter: changes other than +1 while watched
  double time_s = 0.0;                  ///< the amplifier's clock at its last tick or request
  double refreshed_s = 0.0;             ///< when the watchdog was last restarted (its clock)
};

class Amplifier {
 public:
  Amplifier(AmplifierSettings settings, AmplifierPlant& plant);

  /// The register tables the amplifier serves (the server's, or a test's).
  void bind(std::span<std::uint16_t> holding, std::span<std::uint16_t> input, std::span<std::uint8_t> coils);

  /// See the file comment. `now_s` is the wall clock (any epoch).
  Decision on_request(std::span<const std::uint8_t> pdu, double now_s) noexcept;
  /// Between requests: the watchdog.
  void tick(double now_s) noexcept;
  /// The normal reply PDU to `pdu` from the current tables, after
  /// on_request() applied it (AP 6.3-6.17). 0 if the request is not one
  /// this amplifier answers.
  std::size_t build_reply(std::span<const std::uint8_t> pdu, std::span<std::uint8_t> out) const noexcept;

  // ---- switches, any thread ----
  /// `count` requests get `what`; `exception_code` for exception, `delay_ms` for late.
  void inject(Injection what, int count = 1, std::uint8_t exception_code = exception::server_device_failure,
              int delay_ms = 0) noexcept;
  /// Sets fault bits as the amplifier's own protection would (over-current ...): power stage off.
  void inject_fault(std::uint16_t bits) noexcept;
  /// The position registers jump by `counts` once, from the next reply on
  /// (the offset stays; the 32-bit count wraps).
  void jump_position(std::int64_t counts) noexcept {
    position_offset_counts_.fetch_add(counts, std::memory_order_relaxed);
  }
  AmplifierState state() const noexcept;
  const AmplifierSettings& settings() const noexcept { return settings_; }

 private:
  std::uint16_t* holding(std::uint16_t address) noexcept;
  std::span<std::uint16_t> state_table() noexcept;  ///< where registers 0-5 are
  /// An injected failure's decision, if one is pending and ends the request.
  bool take_injection(Decision& decision) noexcept;
  /// 02 when the request reaches past the tables it reads or writes, else 0 (AP 4.4, 7).
  std::uint8_t address_exception(const Request& request) const noexcept;
  void apply(const Request& request, double now_s) noexcept;
  void apply_write(std::uint16_t address, std::uint16_t value, double now_s) noexcept;
  void set_enable(bool on, double now_s) noexcept;
  void restart_watchdog(double period_s, double now_s) noexcept;
  void on_alive_count(std::uint16_t value, double now_s) noexcept;
  void trip_watchdog(double now_s) noexcept;
  void refresh_state_registers() noexcept;
  void publish() noexcept;

  AmplifierSettings settings_;
  AmplifierPlant& plant_;
  std::span<std::uint16_t> holding_, input_;
  std::span<std::uint8_t> coils_;

  // Server-thread state.
  bool enabled_ = false;
  bool watchdog_armed_ = false;
  double watchdog_deadline_s_ = 0.0;
  double watchdog_period_s_ = 0.0;
  std::uint16_t fault_ = 0;
  std::int16_t torque_counts_ = 0;
  double applied_ = 0.0;
  std::uint64_t steps_ = 0, requests_ = 0, trips_ = 0, resets_ = 0;
  double trip_silence_s_ = 0.0;
  double now_s_ = 0.0, refreshed_s_ = 0.0;
  std::uint16_t watchdog_value_ = 0;
  std::uint64_t alive_jumps_ = 0;

  // Switches.
  std::atomic<Injection> injection_{Injection::none};
  std::atomic<int> injection_left_{0};
  std::atomic<std::uint8_t> injection_code_{0};
  std::atomic<int> injection_delay_ms_{0};
  std::atomic<std::uint16_t> pending_fault_{0};
  std::atomic<std::int64_t> position_offset_counts_{0};

  // Published view.
  std::atomic<bool> pub_enabled_{false}, pub_armed_{false};
  std::atomic<std::uint16_t> pub_fault_{0}, pub_watchdog_value_{0};
  std::atomic<std::int16_t> pub_counts_{0};
  std::atomic<double> pub_applied_{0.0}, pub_trip_silence_{0.0}, pub_time_{0.0}, pub_refreshed_{0.0};
  std::atomic<std::uint64_t> pub_steps_{0}, pub_requests_{0}, pub_trips_{0}, pub_resets_{0},
      pub_alive_jumps_{0};
};

}  // namespace hapticd::drivers::modbus::sim
