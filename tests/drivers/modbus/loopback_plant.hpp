#pragma once
// The shared plant simulator behind the simulated amplifier, owned together
// (the tests' plant: the loopback device's plant).
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/modbus/simulator_plant.hpp"

namespace hapticd::drivers::modbus::testing {

class LoopbackPlant final : public sim::AmplifierPlant {
 public:
  explicit LoopbackPlant(const simulation::PlantConfig& config = {})
      : simulator_(config), port_(simulator_) {}
  IoResult sense(double& position) noexcept override { return port_.sense(position); }
  double velocity() const noexcept override { return port_.velocity(); }
  IoResult step(double force) noexcept override { return port_.step(force); }
  simulation::PlantSimulator& simulator() noexcept { return simulator_; }

 private:
  simulation::PlantSimulator simulator_;
  sim::SimulatorPlant port_;
};

}  // namespace hapticd::drivers::modbus::testing
