#pragma once
/// \file
/// The canopen driver's hooks: a CiA 402 drive in cyclic synchronous torque
/// over SocketCAN (or the unix: seam of the simulated drive). The work is
/// the session's (canopen_session.hpp); this file maps it onto the hooks,
/// the health, the device model and the commissioning methods
/// device.sdo.read / device.sdo.write. The framework's Device holds the
/// lifecycle. See README.md.

#include <memory>
#include <string>
#include <vector>

#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/canopen_session.hpp"
#include "drivers/device_hooks.hpp"
#include "drivers/driver_description.hpp"

namespace hapticd::drivers::canopen {

class CanopenDevice final : public DeviceHooks {
 public:
  /// Validates the config (throws ConfigError naming the key).
  explicit CanopenDevice(CanopenConfig config);
  ~CanopenDevice() override;

  void configure(const LoopContext& loop) override;
  void enable() override;
  std::string clear_fault() override;
  void disable() noexcept override;
  void close() noexcept override;

  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;

  DeviceModel model() const override;
  DeviceHealth health() const override;
  std::vector<DeviceMethod> methods() override;

  const CanopenConfig& config() const noexcept { return config_; }

 private:
  CanopenConfig config_;
  std::unique_ptr<CanopenSession> session_;  ///< from configure() to close()
};

}  // namespace hapticd::drivers::canopen
