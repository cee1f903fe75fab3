#pragma once
/// \file
/// The loopback driver's hooks: the shared plant simulator behind the
/// framework's Device (drivers/device.hpp), for tests and demos. write() advances the plant by exactly one
/// period (simulated time = writes * T, independent of the wall clock);
/// read() returns the encoder's position. The scripted hand and fault
/// injection are control-plane methods of this driver (hand.set,
/// fault.inject), not special cases of the daemon. See README.md.
///
/// Threads: read()/write() belong to one RT thread. The lifecycle runs off
/// the RT path; clear_fault(), methods(), health() and the simulator's
/// thread-safe calls (set_hand, inject_fault, snapshot) may run at any time.

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/device.hpp"
#include "drivers/device_hooks.hpp"
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/simulation/plant_simulator.hpp"

namespace hapticd::drivers::loopback {

using simulation::Fault;
using simulation::HandScript;
using simulation::PlantSnapshot;

class LoopbackDevice final : public DeviceHooks {
 public:
  /// Validates the config (throws std::invalid_argument) and builds the
  /// simulator for config.period_s (configure() rebuilds it if the loop's
  /// period differs).
  explicit LoopbackDevice(const LoopbackConfig& config, const HandScript& hand = {});
  /// A Cartesian stage: one simulator per axis (stage.axes.size() of them,
  /// 1 to max_axes); one axis is the constructor above. A pantograph
  /// (stage.pantograph): one simulator per motor joint, at the joint angles
  /// of the handle's start, and the hand on the handle.
  explicit LoopbackDevice(const LoopbackStage& stage);
  ~LoopbackDevice() override;

  void configure(const LoopContext& loop) override;
  void enable() override;
  std::string clear_fault() override;
  void disable() noexcept override;
  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;
  int axes() const noexcept override { return static_cast<int>(simulators_.size()); }
  /// Every axis' encoder at the same instant (before any axis steps).
  IoResult read_axes(std::span<Reading> out) noexcept override;
  /// Every axis' force, then each plant advances one period.
  IoResult write_axes(std::span<const double> forces) noexcept override;
  DeviceModel model() const override;
  DeviceHealth health() const override;
  /// hand.set and fault.inject (docs/protocol.md).
  std::vector<DeviceMethod> methods() override;

  /// The first axis' simulator (the only one of a one-axis loopback).
  simulation::PlantSimulator& simulator() noexcept { return *simulators_.front(); }
  const simulation::PlantSimulator& simulator() const noexcept { return *simulators_.front(); }
  /// Axis `index`'s simulator, 0-based.
  simulation::PlantSimulator& simulator(std::size_t index) { return *simulators_.at(index); }
  /// A pantograph's hand on the handle (nullptr for a stage or one axis).
  simulation::PantographHand* pantograph_hand() noexcept { return linkage_.get(); }

  // The simulator's own calls, for tests and tools.
  const LoopbackConfig& config() const noexcept { return simulator().config(); }
  const world::LinearPlant& plant_model() const noexcept { return simulator().plant_model(); }
  std::optional<world::TwoMassPlant> two_mass() const { return simulator().two_mass(); }
  void set_hand(const HandScript& script) { simulator().set_hand(script); }
  void set_hand(std::string_view text) { simulator().set_hand(text); }
  HandScript hand() const { return simulator().hand(); }
  /// On every axis.
  void inject_fault(Fault fault, std::int64_t amount = -1) noexcept {
    for (auto& axis : simulators_) axis->inject_fault(fault, amount);
  }
  void clear_faults() noexcept {
    for (auto& axis : simulators_) axis->clear_faults();
  }
  PlantSnapshot snapshot() const noexcept { return simulator().snapshot(); }
  /// Only while the RT thread is not stepping the plant (disabled).
  void set_initial_state(double position, double velocity) {
    simulator().set_initial_state(position, velocity);
  }

 private:
  /// hand.set on a pantograph: the handle (no axis) or a joint's own script.
  nlohmann::json set_pantograph_hand(const nlohmann::json& params);
  /// The joints at the handle's start, at rest.
  void start_pantograph();
  void add_link_weight(const std::array<double, 2>& q,
                       std::array<simulation::JointDrive, 2>& drives) const noexcept;

  std::vector<std::unique_ptr<simulation::PlantSimulator>> simulators_;  ///< one per axis
  std::optional<LoopbackStage::Pantograph> pantograph_;                  ///< linkage = pantograph
  std::unique_ptr<simulation::PantographHand> linkage_;                  ///< its hand on the handle
  std::uint64_t steps_ = 0;                                              ///< write_axes() calls (RT)
};

/// The framework's Device around a loopback driver (tests, tools).
std::unique_ptr<Device> make_loopback_device(const LoopbackConfig& config, const HandScript& hand = {});

}  // namespace hapticd::drivers::loopback
