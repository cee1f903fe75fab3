#pragma once
/// \file
/// The usb-hid driver's hooks over BoardLink (which holds the transport and
/// the host session), and the driver's registry entry (typed parameters,
/// README.md "Configuration"). The framework's Device holds the lifecycle.

#include <memory>
#include <string>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/driver_description.hpp"
#include "drivers/parameter.hpp"
#include "drivers/usb_hid/board_link.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"

namespace hapticd::drivers::usb_hid {

class UsbHidDevice final : public DeviceHooks {
 public:
  explicit UsbHidDevice(const UsbHidConfig& config);
  ~UsbHidDevice() override;

  void configure(const LoopContext& loop) override;
  void enable() override;
  std::string clear_fault() override;
  void disable() noexcept override;
  void close() noexcept override;
  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;
  DeviceModel model() const override;
  DeviceHealth health() const override;

  const UsbHidConfig& config() const noexcept { return link_.config(); }
  LinkStatus link_status() const { return link_.status(); }

 private:
  BoardLink link_;
};

}  // namespace hapticd::drivers::usb_hid
