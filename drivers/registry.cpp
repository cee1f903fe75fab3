#include "drivers/registry.hpp"

#include "drivers/planned.hpp"
#include "world/text.hpp"

/// Every driver, one line each, in documentation order: the namespace in
/// hapticd::drivers whose <kind>_driver() (drivers/<kind>/<kind>_driver.cpp)
/// describes it. A new driver adds its line here and touches nothing else
/// outside its folder.
#define HAPTICD_EACH_DRIVER(X) \
  X(loopback)                  \
  X(usb_hid)                   \
  X(canopen)                   \
  X(modbus)                    \
  X(gpio_pwm)                  \
  X(skeleton)                  \
  /* a new driver: one line above */

namespace hapticd::drivers {

#define HAPTICD_DECLARE_DRIVER(kind) \
  namespace kind {                   \
  DriverDescription kind##_driver(); \
  }
HAPTICD_EACH_DRIVER(HAPTICD_DECLARE_DRIVER)
#undef HAPTICD_DECLARE_DRIVER

const std::vector<DriverDescription>& driver_registry() {
#define HAPTICD_DESCRIBE_DRIVER(kind) kind::kind##_driver(),
  static const std::vector<DriverDescription> drivers{HAPTICD_EACH_DRIVER(HAPTICD_DESCRIBE_DRIVER)};
#undef HAPTICD_DESCRIBE_DRIVER
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
