#pragma once
/// \file
/// The shared plant simulator behind the simulated amplifier.
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/modbus/amplifier.hpp"

namespace hapticd::drivers::modbus::sim {

class SimulatorPlant final : public AmplifierPlant {
 public:
  explicit SimulatorPlant(simulation::PlantSimulator& plant) : plant_(plant) {}
  IoResult sense(double& position) noexcept override { return plant_.sense(position); }
  double velocity() const noexcept override { return plant_.snapshot().motor_velocity; }
  IoResult step(double force) noexcept override { return plant_.step(force); }

 private:
  simulation::PlantSimulator& plant_;
};

}  // namespace hapticd::drivers::modbus::sim
