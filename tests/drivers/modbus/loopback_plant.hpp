#pragma once
// The loopback device's plant behind the simulated amplifier, for the
// tests until the shared plant simulator (drivers/simulation) is on main.
#include "drivers/loopback/loopback_device.hpp"
#include "drivers/modbus/sim/amplifier.hpp"

namespace hapticd::drivers::modbus::testing {

class LoopbackPlant final : public sim::AmplifierPlant {
 public:
  explicit LoopbackPlant(const loopback::LoopbackConfig& config = {}) : device_(config) { device_.start(); }
  IoResult sense(double& position) noexcept override {
    Reading r;
    const IoResult result = device_.read(r);
    position = r.position;
    return result;
  }
  double velocity() const noexcept override { return device_.snapshot().motor_velocity; }
  IoResult step(double force) noexcept override { return device_.write(force); }
  loopback::LoopbackDevice& device() noexcept { return device_; }

 private:
  loopback::LoopbackDevice device_;
};

}  // namespace hapticd::drivers::modbus::testing
