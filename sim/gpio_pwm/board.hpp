#pragma once
/// \file
/// The simulated board behind the umockdev testbed: an H-bridge (Amplifier)
/// fed by the PWM channel and the enable/direction/brake lines, a motor and
/// its load (a BoardPlant: the shared plant simulator in the peer), an
/// encoder read either by a kernel counter (SimulatedCounter) or on two GPIO
/// lines (edges), a fault output and a reset input, and the external
/// charge-pump watchdog.
///
/// Lockstep: the board advances one period each time the driver sets the
/// output lines (the GPIOHANDLE_SET_LINE_VALUES_IOCTL of the request that
/// holds the direction line, which the driver issues once per write(),
/// after the period's duty write, and once more in disable(): the plant
/// keeps moving while the stage goes off). Inside that ioctl, before it returns,
/// the board reads the lines and the PWM channel, steps the amplifier and
/// the plant, and publishes the new position: the counter's count file, or
/// the encoder's edges queued on the A/B lines with timestamps spread over
/// the period. So a run is deterministic and period n's read() sees the
/// state after n writes, as on the loopback device.

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "drivers/simulation/plant_simulator.hpp"
#include "sim/gpio_pwm/amplifier.hpp"
#include "sim/gpio_pwm/quadrature_encoder.hpp"
#include "sim/gpio_pwm/sysfs_peripherals.hpp"
#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

/// The motor, what it moves and its encoder: one period under a motor force.
class BoardPlant {
 public:
  virtual ~BoardPlant() = default;
  /// Applies `motor_force` (N or N m) over one period.
  virtual void step(double motor_force) = 0;
  /// The encoder's count now (its own quantization, faults included).
  virtual std::int64_t encoder_counts() const = 0;
  /// The position at the encoder now (m or rad), for the board's record.
  virtual double position() const = 0;
};

/// The shared plant simulator (drivers/simulation) as the board's plant:
/// the same plant, hand, friction, saturation and encoder as a loopback
/// run, so a gpio-pwm run compares with it sample by sample.
class SimulatorPlant final : public BoardPlant {
 public:
  explicit SimulatorPlant(std::unique_ptr<simulation::PlantSimulator> simulator);
  void step(double motor_force) override;
  std::int64_t encoder_counts() const override;
  double position() const override;
  simulation::PlantSimulator& simulator() { return *simulator_; }

 private:
  void sense();
  std::unique_ptr<simulation::PlantSimulator> simulator_;
  double resolution_;
  double sensed_ = 0.0;  // once per period: sense() counts injected read faults
};

/// How the board is wired to the chip (offsets on the simulated chip, and
/// which level of each signal is its active one).
struct BoardWiring {
  unsigned enable = 0;
  unsigned direction = 1;
  std::optional<unsigned> fault, brake, reset, charge_pump, encoder_a, encoder_b;
  bool enable_active_low = false, direction_active_low = false, fault_active_low = false;
  bool brake_active_low = false, reset_active_low = false;
  bool encoder_a_active_low = false, encoder_b_active_low = false;
  unsigned pwm_channel = 0;
  bool pwm_input_active_low = false;  ///< the bridge's PWM input is active low (drive it "inversed")
};

struct BoardConfig {
  BoardWiring wiring;
  AmplifierConfig amplifier;
  double period_s = 1e-3;
  double counts_per_unit = 16384.0 / (2.0 * 3.14159265358979323846);  ///< counts per rad (or per m)
  bool encoder_reverse = false;                                       ///< counts fall as the position rises
};

/// What the board saw and did in one period.
struct BoardPeriod {
  std::uint64_t index = 0;
  bool enable = false, direction_positive = true, brake = false, charge_pump = false;
  double pwm_fraction = 0.0;  ///< of the period the bridge was driven
  double motor_force = 0.0;
  bool powered = false;
  double position = 0.0;
  std::int64_t counts = 0;
};

class SimulatedBoard {
 public:
  /// `counter` may be null (then the encoder lines must be wired). Installs
  /// itself as the testbed's values observer; the references must outlive it.
  SimulatedBoard(UmockdevGpioTestbed& gpio, SimulatedPwmChip& pwm, SimulatedCounter* counter,
                 BoardConfig config, std::unique_ptr<BoardPlant> plant);
  ~SimulatedBoard();
  SimulatedBoard(const SimulatedBoard&) = delete;
  SimulatedBoard& operator=(const SimulatedBoard&) = delete;

  /// The power stage trips now: off, fault line active (an edge the driver
  /// sees at its next read()).
  void trip(const std::string& reason);
  /// Called at each period's commit before the period is stepped, on
  /// umockdev's worker thread, without the board's lock (it may trip()).
  void set_before_period(std::function<void()> hook);
  /// Time passes without the driver (a killed or hung hapticd): the
  /// amplifier and plant advance with the lines as they were left.
  void advance_idle(unsigned periods);

  std::vector<BoardPeriod> history() const;
  std::uint64_t periods() const;
  bool fault() const;
  std::string fault_reason() const;
  std::uint64_t resets() const;
  bool watchdog_expired() const;
  std::int64_t counts() const;
  BoardPlant& plant() { return *plant_; }

 private:
  void on_values(RequestId request);
  void step_period(const AmplifierInputs& in);
  void publish_position(std::int64_t counts, std::uint64_t from_ns, std::uint64_t to_ns);
  void drive_fault(bool active);
  bool logical(unsigned offset, bool active_low);

  UmockdevGpioTestbed& gpio_;
  SimulatedPwmChip& pwm_;
  SimulatedCounter* counter_;
  BoardConfig config_;
  std::unique_ptr<BoardPlant> plant_;
  mutable std::mutex mutex_;
  Amplifier amplifier_;
  QuadratureEncoder encoder_;
  AmplifierInputs last_inputs_;
  std::uint64_t period_ = 0;
  std::int64_t counts_ = 0;
  std::vector<BoardPeriod> history_;
  std::function<void()> before_period_;  // set before the driver runs
};

}  // namespace hapticd::drivers::gpio_pwm::sim
