#include "drivers/registry.hpp"

#include "drivers/canopen/canopen_device.hpp"
#include "drivers/gpio_pwm/gpio_pwm_config.hpp"
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/modbus/modbus_driver.hpp"
#include "drivers/planned.hpp"
#include "drivers/usb_hid/usb_hid_device.hpp"
#include "world/text.hpp"

namespace hapticd::drivers {

const std::vector<DriverDescription>& driver_registry() {
  // One line per driver; a driver issue replaces its planned entry here.
  static const std::vector<DriverDescription> drivers{
      loopback::loopback_driver(),  // drivers/loopback
      usb_hid::usb_hid_driver(),    // drivers/usb_hid
      canopen::canopen_driver(),    // drivers/canopen
      modbus::modbus_driver(),      // drivers/modbus
      gpio_pwm::gpio_pwm_driver(),  // drivers/gpio_pwm
  };
  return drivers;
}

const DriverDescription* find_driver(std::string_view name) noexcept {
  for (const auto& d : driver_registry()) {
    if (d.name == name) return &d;
  }
  return nullptr;
}

std::string driver_names(bool ready_only) {
  std::vector<std::string> names;
  for (const auto& d : driver_registry()) {
    if (!ready_only || d.ready) names.push_back(d.name);
  }
  return world::text::join(names);
}

}  // namespace hapticd::drivers
