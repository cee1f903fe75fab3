// The skeleton driver's description (drivers/driver_description.hpp): its
// name, one line, its typed parameters and the factory of its hooks. The
// registry (drivers/registry.cpp) lists it with one line.
#include "drivers/driver_description.hpp"
#include "drivers/skeleton/skeleton_config.hpp"
#include "drivers/skeleton/skeleton_device.hpp"

namespace hapticd::drivers::skeleton {

DriverDescription skeleton_driver() {
  return {"skeleton",
          "a blank driver to copy (docs/drivers.md): one 8-byte exchange a period with a peer on a unix "
          "SOCK_SEQPACKET socket",
          true, skeleton_parameters(), [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            return std::make_unique<SkeletonDevice>(skeleton_config_from(p));
          }};
}

}  // namespace hapticd::drivers::skeleton
