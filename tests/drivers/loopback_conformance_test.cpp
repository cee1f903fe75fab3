// The loopback device through the conformance suite every driver passes.

#include "drivers/loopback/loopback_device.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;

struct LoopbackConformance {
  static constexpr const char* driver = "loopback";
  ParameterTable parameters() { return {}; }  // the driver's defaults: a rigid wheel
  double period_s() { return 1e-3; }
  static hapticd::drivers::loopback::LoopbackDevice& loopback(hapticd::drivers::Device& device) {
    return device.hooks_as<hapticd::drivers::loopback::LoopbackDevice>();
  }
  void inject_device_fault(hapticd::drivers::Device& device) {
    loopback(device).inject_fault(hapticd::drivers::simulation::Fault::fault);
  }
  double observed_output(hapticd::drivers::Device& device) {
    return loopback(device).snapshot().applied_force;
  }
  std::vector<BadParameters> bad_parameters() {
    return {{{{"mass", -1.0}}, "mass"},
            {{{"delay", 65.0}}, "delay"},
            {{{"motion", std::string("spherical")}}, "motion"},
            {{{"plant", std::string("two-mass")}, {"cable_stiffness", 0.0}}, "cable_stiffness"},
            {{{"hand", std::string("mode=fly")}}, "hand"}};
  }
};

}  // namespace

namespace hapticd::testing::loopback_conformance_test {
INSTANTIATE_TYPED_TEST_SUITE_P(Loopback, DeviceConformance, LoopbackConformance);
}  // namespace hapticd::testing::loopback_conformance_test
