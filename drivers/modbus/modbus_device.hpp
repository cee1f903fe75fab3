#pragma once
/// \file
/// The `modbus` driver's hooks: a servo amplifier over Modbus RTU or TCP. README.md
/// in this folder is the protocol note (wire, timing, errors, watchdog).
///
/// RT path: read() makes the period's transaction (writes the command
/// write() stored in the previous period, with the watchdog, and reads
/// position, velocity, status and fault); write() only stores the command.
/// Bounded by the response timeout per transaction (1 with fc 23, 2 with
/// fc 16 + 3/4); no allocation, lock or text.
///
/// Threads: one libmodbus context. The RT thread takes it for each read()
/// by a compare-exchange on an owner word and never waits; the control
/// thread (enable, clear_fault, disable, close) takes it when the RT thread
/// is not inside a transaction, waiting at most a second. Whoever owns the
/// context is the one writer of the fault record and the sample (seqlocks).
///
/// Keep-alive: the watchdog is armed at configure, but the loop's periods
/// start only after the stability gate, enable() and the engine's start. A
/// keep-alive thread makes the periodic exchange with torque 0 every period
/// (at most every 5 ms) until the RT thread's first read(), and again after
/// disable(); never while the loop runs, so a dead loop still lets the
/// watchdog expire. The RT thread's first read() may find one keep-alive
/// exchange in flight and waits for it (bounded by the response timeout):
/// the only wait on the RT path, once after each enable.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "drivers/device_hooks.hpp"
#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_link.hpp"
#include "drivers/modbus/register_map.hpp"
#include "rt/seqlock.hpp"

namespace hapticd::drivers::modbus {

/// Why the device latched a fault (RT-safe: no text; describe() renders it).
enum class FaultCause : std::uint8_t {
  none,
  exception,           ///< a non-transient exception reply
  failure_streak,      ///< failure_streak transactions in a row timed out, had a bad CRC or a malformed reply
  closed,              ///< connection closed or device gone
  io_error,            ///< another system error
  amplifier_fault,     ///< status fault bit or fault word
  amplifier_disabled,  ///< the power stage went off by itself
};

/// The link budget found at configure.
struct LinkBudget {
  int transactions = 1;
  int frames_per_period = 2;
  int bytes_per_period = 0;                                  ///< RTU ADU bytes (TCP: PDU + MBAP)
  double response_timeout_s = 0.0;                           ///< in force
  double computed_cycle_s = 0.0;                             ///< RTU: from the formula (0 for TCP)
  double rtt_p50_s = 0.0, rtt_p99_s = 0.0, rtt_max_s = 0.0;  ///< TCP: measured at configure (per period)
  int rtt_samples = 0;
  std::string summary;  ///< one line with the figures
};

/// The last decoded read block, in counts and SI.
struct ModbusSample {
  AmplifierSample raw;
  double position = 0.0;  ///< rad or m
  double velocity = 0.0;  ///< rad/s or m/s
  std::uint64_t period = 0;
};

class ModbusDevice final : public DeviceHooks {
 public:
  explicit ModbusDevice(ModbusConfig config);
  ~ModbusDevice() override;
  ModbusDevice(const ModbusDevice&) = delete;
  ModbusDevice& operator=(const ModbusDevice&) = delete;

  // Non-RT lifecycle.
  void configure(const LoopContext& loop) override;
  void enable() override;
  std::string clear_fault() override;
  void disable() noexcept override;
  void close() noexcept override;

  // RT.
  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;

  // Any non-RT thread.
  DeviceModel model() const override;
  DeviceHealth health() const override;
  LinkBudget budget() const;
  ModbusSample sample() const;
  const ModbusConfig& config() const noexcept { return config_; }

 private:
  enum Owner : int { free_owner = 0, rt_owner = 1, control_owner = 2, keepalive_owner = 3 };
  struct FaultRecord {
    FaultCause cause = FaultCause::none;
    LinkResult last;
    std::uint16_t status = 0, fault_word = 0;
    int streak = 0;
  };

  // Owner of the context only.
  IoResult exchange(Reading& out) noexcept;
  LinkResult transact(std::int16_t torque, std::uint16_t watchdog) noexcept;
  /// The watchdog register's next value: watchdog_value, or the alive counter's next count.
  std::uint16_t watchdog_word() noexcept;
  IoResult latch(FaultCause cause, const LinkResult& last, const AmplifierSample& s) noexcept;
  void publish_sample(const AmplifierSample& s) noexcept;
  AmplifierSample read_state(const char* doing, int retries = 0);  ///< non-RT, throws DeviceError
  void set_power_stage(bool on);                                   ///< non-RT, throws DeviceError
  void wait_enabled(const char* doing);                            ///< non-RT, throws DeviceError
  void write_zero_command(const char* doing);                      ///< non-RT, throws DeviceError
  FaultRecord fault_record() const;
  std::string describe(const FaultRecord& record) const;
  [[noreturn]] void fail(const std::string& doing, const LinkResult& r, const std::string& key = {}) const;

  // Control thread: take and give back the context.
  // Control-thread exchanges wait up to control_timeout_s() (connect_timeout,
  // at least the response timeout): they have no period to fit.
  void acquire_control(const char* doing);
  void release_control() noexcept;
  double control_timeout_s() const noexcept;
  void set_timeout(double seconds) noexcept;

  void check_period(double period_s);
  void measure_round_trip();
  void start_keepalive();
  void stop_keepalive() noexcept;
  void keepalive_loop() noexcept;

  ModbusConfig config_;
  StopToken stop_;  ///< the daemon's stop request, from configure's LoopContext
  BlockLayout layout_;
  std::unique_ptr<ModbusLink> link_;
  LinkBudget budget_;
  double period_s_ = 0.0;

  std::atomic<int> owner_{free_owner};
  std::atomic<bool> expect_enabled_{false};
  std::atomic<bool> latched_{false};
  std::atomic<std::int16_t> command_counts_{0};
  std::atomic<bool> rt_active_{false};  ///< the RT thread has taken over the periodic exchange
  std::atomic<bool> keepalive_stop_{false};
  std::thread keepalive_;

  // Owner-of-the-context state.
  bool link_down_ = false;
  double transact_round_trip_s_ = 0.0;  ///< of the last transact(): the link's round trip(s)
  int streak_ = 0;
  std::uint64_t period_ = 0;
  std::uint16_t alive_count_ = 0;     ///< watchdog_refresh = counter: the next value (wraps in 16 bits)
  bool power_off_confirmed_ = false;  ///< disable() switched the power stage off: close() may disarm
  std::array<std::uint16_t, 2> write_block_{};
  std::array<std::uint16_t, 125> read_block_{};

  // Fault record (seqlock, written by the context's owner).
  rt::SeqlockVersion fault_version_;
  std::atomic<FaultCause> f_cause_{FaultCause::none};
  std::atomic<LinkOutcome> f_outcome_{LinkOutcome::ok};
  std::atomic<std::uint8_t> f_function_{0}, f_exception_{0};
  std::atomic<FrameProblem> f_problem_{FrameProblem::none};
  std::atomic<std::uint16_t> f_got_{0}, f_expected_{0};
  std::atomic<int> f_errno_{0}, f_streak_{0};
  std::atomic<std::uint16_t> f_status_{0}, f_fault_{0};

  // Last sample (seqlock, written by the context's owner).
  rt::SeqlockVersion sample_version_;
  std::atomic<std::int32_t> s_position_{0}, s_velocity_{0};
  std::atomic<std::uint16_t> s_status_{0}, s_fault_{0};
  std::atomic<bool> s_enabled_{false}, s_faulted_{false};
  std::atomic<std::uint64_t> s_period_{0};

  // Counters (relaxed; one writer each).
  std::atomic<std::uint64_t> saturations_{0}, busy_{0};
};

}  // namespace hapticd::drivers::modbus
