// The usb-hid Device through the conformance suite every driver passes, built
// through the registry as the daemon builds it, against the simulated board
// (the shared plant simulator behind the firmware) on an emulated USB bus.

#include <memory>

#include "drivers/simulation/plant_simulator.hpp"
#include "sim/usb_hid/simulated_board.hpp"
#include "sim/usb_hid/umockdev_board.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

using hapticd::drivers::Motion;
using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;
namespace sim = hapticd::drivers::usb_hid::sim;
namespace simulation = hapticd::drivers::simulation;

struct UsbHidConformance {
  static constexpr const char* driver = "usb-hid";

  UsbHidConformance()
      : config(simulation::PlantConfig::defaults(Motion::rotary)),
        simulator(config),
        plant(simulator),
        board(scaling(), plant),
        testbed(sim::EmulatedUsbIdentity{}, board) {}

  sim::BoardScaling scaling() const {
    sim::BoardScaling s;
    s.position_per_count = config.resolution();
    s.command_full_scale = 1.0;
    s.period_s = 1e-3;
    return s;
  }
  ParameterTable parameters() {
    return {{"vendor_id", std::string("0x1209")},
            {"product_id", std::string("0x0001")},
            {"counts_per_unit", config.counts}};
  }
  double period_s() { return 1e-3; }
  void inject_device_fault(hapticd::drivers::Device&) {
    board.raise_fault(sim::FaultCode::over_temperature, false);
  }
  double observed_output(hapticd::drivers::Device&) { return board.snapshot().applied_force; }
  std::vector<BadParameters> bad_parameters() {
    auto with = [this](const char* key, hapticd::drivers::ParameterValue value) {
      ParameterTable t = parameters();
      t[key] = std::move(value);
      return t;
    };
    ParameterTable no_product = parameters();
    no_product.erase("product_id");
    return {{with("vendor_id", std::string("0x12345")), "vendor_id"},
            {no_product, "product_id"},
            {with("in_position", std::string("3:i32le")), "in_position"},
            {with("in_endpoint", std::string("0x01")), "in_endpoint"},
            {with("in_transfers", 1.0), "in_transfers"},
            {with("serial", std::string("NOPE")), "serial"},
            {with("path", std::string("1-7")), "path"},
            {with("product_id", std::string("0x0002")), "vendor_id"}};
  }

  simulation::PlantConfig config;
  simulation::PlantSimulator simulator;
  sim::SimulatorPlant plant;
  sim::SimulatedBoard board;
  sim::UmockdevUsbBoard testbed;
};

}  // namespace

namespace hapticd::testing::usb_hid_conformance_test {
INSTANTIATE_TYPED_TEST_SUITE_P(UsbHid, DeviceConformance, UsbHidConformance);
}  // namespace hapticd::testing::usb_hid_conformance_test
