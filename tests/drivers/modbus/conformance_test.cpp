// The modbus device through the conformance suite every driver passes, over
// TCP and over RTU, each against its own simulated amplifier.
#include <memory>

#include "drivers/modbus/modbus_config.hpp"
#include "loopback_plant.hpp"
#include "sim/modbus/amplifier_server.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

namespace mb = hapticd::drivers::modbus;
using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;

template <bool Rtu>
struct ModbusConformance {
  static constexpr const char* driver = "modbus";
  ModbusConformance() : config(mb::modbus_config({})), amplifier(settings(config), plant) {
    server = Rtu ? mb::sim::AmplifierServer::rtu_pty(amplifier) : mb::sim::AmplifierServer::tcp(amplifier);
    server->start();
    (void)server->make_realtime(70);  // as an amplifier is its own hardware, when permitted
  }
  ~ModbusConformance() { server->stop(); }
  static mb::sim::AmplifierSettings settings(const mb::ModbusConfig& c) {
    mb::sim::AmplifierSettings s;
    s.position_per_count = c.position_per_count();
    s.torque_per_count = c.torque_per_count;
    return s;
  }
  // A 50 ms period with most of it for the link and a 1 s watchdog: no
  // timeout or watchdog trip from the VM's stalls.
  ParameterTable parameters() {
    ParameterTable t{{"link_budget", 0.9}, {"rtt_samples", 10.0}, {"watchdog_value", 1000.0}};
    if (Rtu) {
      t["transport"] = std::string("rtu");
      t["device"] = server->slave_path();
      t["baud"] = 4000000.0;
      t["silence"] = std::string("characters");
    } else {
      t["port"] = static_cast<double>(server->port());
    }
    return t;
  }
  double period_s() { return 50e-3; }
  void inject_device_fault(hapticd::drivers::Device&) { amplifier.inject_fault(0x0001); }  // over-current
  double observed_output(hapticd::drivers::Device&) { return amplifier.state().applied_torque; }
  std::vector<BadParameters> bad_parameters() {
    ParameterTable slow = parameters();
    slow["baud"] = 9600.0;  // 47 ms a cycle > 0.9 x 50 ms
    slow["transport"] = std::string("rtu");
    slow["device"] = std::string("/dev/null");
    slow["silence"] = std::string("spec");
    ParameterTable wrong = parameters();
    wrong["watchdog_register"] = 40.0;
    ParameterTable rate = parameters();
    rate["baud"] = 2000000.0;
    ParameterTable timeout = parameters();
    timeout["response_timeout"] = 0.049;
    return {{slow, "baud"}, {wrong, "watchdog_register"}, {rate, "baud"}, {timeout, "response_timeout"}};
  }

  mb::ModbusConfig config;
  mb::testing::LoopbackPlant plant;
  mb::sim::Amplifier amplifier;
  std::unique_ptr<mb::sim::AmplifierServer> server;
};

using ModbusTcpConformance = ModbusConformance<false>;
using ModbusRtuConformance = ModbusConformance<true>;

}  // namespace

namespace hapticd::testing::conformance_test {
INSTANTIATE_TYPED_TEST_SUITE_P(ModbusTcp, DeviceConformance, ModbusTcpConformance);
INSTANTIATE_TYPED_TEST_SUITE_P(ModbusRtu, DeviceConformance, ModbusRtuConformance);
}  // namespace hapticd::testing::conformance_test
