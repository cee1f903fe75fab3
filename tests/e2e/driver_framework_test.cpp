// The driver framework end to end: the registry as hapticd lists it, a
// planned driver refused in one line at its key, the device described from
// its driver's own table, the loopback's methods as methods of its driver,
// and fault clear saying what it cleared on the device.

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "tests/e2e/support.hpp"

namespace hapticd::e2e::driver_framework_test {
namespace {

using nlohmann::json;

TEST(DriverFramework, ListDriversJsonGivesEveryDriverTypedAndWhetherItIsReady) {
  const auto r = run(hapticd_binary(), {"--list-drivers", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json drivers = json::parse(r.out);
  std::map<std::string, std::string> status;
  for (const auto& d : drivers) {
    status[d["name"]] = d["status"];
    EXPECT_FALSE(d["summary"].get<std::string>().empty());
    for (const auto& p : d["parameters"]) {
      EXPECT_TRUE(p.contains("type") && p.contains("unit") && p.contains("help")) << p.dump();
    }
  }
  for (const char* ready : {"loopback", "usb-hid", "canopen", "modbus"})
    EXPECT_EQ(status[ready], "ready") << ready;
  EXPECT_TRUE(status.count("gpio-pwm"));
}

TEST(DriverFramework, UnknownDriverAndAMissingRequiredKeyAreOneLine) {
  TempDir dir;
  const auto config = dir.path / "c.toml";
  std::ofstream(config) << "[loop]\nperiod = \"1ms\"\n[device]\ndriver = \"warp-drive\"\n";
  auto r = run(hapticd_binary(), {"--check-config", "-c", config.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(
      r.err.find("c.toml:4:10: device.driver = \"warp-drive\" is not a known driver; accepted: loopback,"),
      std::string::npos)
      << r.err;
  // No driver is planned any more (gpio-pwm was the last): a ready driver
  // without its table is refused at its first required key.
  std::ofstream(config) << "[device]\ndriver = \"gpio-pwm\"\n";
  r = run(hapticd_binary(), {"--check-config", "-c", config.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("device.gpio-pwm.mass is required; accepted: a number in"), std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(DriverFramework, DeviceParameterErrorIsAtTheExactKey) {
  TempDir dir;
  const auto config = dir.path / "c.toml";
  // "mass" is a substring of "motor_mass": the error is at motor_mass's line.
  std::ofstream(config) << "[device]\ndriver = \"loopback\"\n[device.loopback]\nplant = \"two-mass\"\n"
                           "mass = 0.01\nmotor_mass = 1e300\n";
  const auto r = run(hapticd_binary(), {"--check-config", "-c", config.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(
      r.err.find("c.toml:6:14: device.loopback.motor_mass = 1e+300 is out of range; accepted: a number in"),
      std::string::npos)
      << r.err;
}

TEST(DriverFramework, DeviceIsDescribedFromItsDriversTableAndClearSaysWhatTheDeviceCleared) {
  TempDir dir;
  Daemon daemon(dir, "[device.loopback]\ncoulomb = 0.001\n");
  auto r = daemon.ctl({"device", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json d = json::parse(r.out);
  EXPECT_EQ(d["driver"]["name"], "loopback");
  EXPECT_EQ(d["values"]["coulomb"], 0.001);  // written
  EXPECT_EQ(d["values"]["mass"], 0.01);      // the driver's default
  EXPECT_EQ(d["state"], "enabled");
  r = daemon.ctl({"device"});
  EXPECT_NE(r.out.find("coulomb = 0.001 N m"), std::string::npos) << r.out;  // the rotary unit

  // The loopback's fault injection is a method of its driver; clear says
  // what it cleared on the device and in the daemon.
  ASSERT_EQ(daemon.ctl({"fault", "inject", "fault"}).exit_code, 0);
  json status;
  for (int i = 0; i < 100; ++i) {
    status = json::parse(daemon.ctl({"status", "--json"}).out);
    if (!status["fault"].is_null()) break;
  }
  EXPECT_EQ(status["fault"], "device fault");
  EXPECT_EQ(status["device"]["state"], "fault");
  EXPECT_NE(status["device"]["fault_reason"].get<std::string>().find("amplifier is off"), std::string::npos);
  r = daemon.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json cleared = json::parse(r.out);
  EXPECT_EQ(cleared["cleared"], "device fault");
  EXPECT_EQ(cleared["device"], "injected fault (until cleared)");
  status = json::parse(daemon.ctl({"status", "--json"}).out);
  EXPECT_TRUE(status["fault"].is_null());
  EXPECT_EQ(status["device"]["state"], "enabled");
  EXPECT_EQ(daemon.stop(), 0);
}

}  // namespace
}  // namespace hapticd::e2e::driver_framework_test
