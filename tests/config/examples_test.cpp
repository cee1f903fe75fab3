// Every configuration shipped in config/ parses. Templates for drivers not
// built yet parse too (the daemon, not the parser, refuses them); they must
// say so in their text.
#include "daemon/config/config.hpp"
#include "drivers/registry.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace hapticd::daemon::config::examples_test {
namespace {

const std::filesystem::path config_dir = std::filesystem::path(HAPTICD_SOURCE_DIR) / "config";

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

const ParameterValue* find(const ParameterList& list, std::string_view key) {
  for (const auto& p : list) {
    if (p.key == key) return &p.value;
  }
  return nullptr;
}

TEST(ShippedConfigs, EveryFileParsesWithTheExpectedDriverAndScene) {
  // file -> (driver, scene)
  const std::map<std::string, std::pair<std::string, std::string>> expected = {
      {"hapticd.toml", {"loopback", "spring-wheel"}},
      {"loopback-wheel.toml", {"loopback", "spring-wheel"}},
      {"loopback-linear-wall.toml", {"loopback", "wall"}},
      {"loopback-two-mass.toml", {"loopback", "relay"}},
      {"loopback-pantograph.toml", {"loopback", "plane-wall"}},
      {"loopback-pantograph-vertical.toml", {"loopback", "free"}},
      {"usb-hid.toml", {"usb-hid", "spring-wheel"}},
      {"canopen.toml", {"canopen", "spring-wheel"}},
      {"modbus.toml", {"modbus", "spring-wheel"}},
      {"gpio-pwm.toml", {"gpio-pwm", "spring-wheel"}},
  };
  std::size_t seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(config_dir)) {
    if (entry.path().extension() != ".toml") continue;
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    const auto it = expected.find(name);
    ASSERT_NE(it, expected.end()) << "new example " << name << ": add it to this test";
    DaemonConfig config;
    ASSERT_NO_THROW(config = load_config(entry.path()));
    EXPECT_EQ(config.device.driver, it->second.first);
    EXPECT_EQ(config.scene.name, it->second.second);
    // Drivers still planned say so in their template; ready ones are real configs.
    if (!hapticd::drivers::find_driver(config.device.driver)->ready) {
      EXPECT_NE(read_text(entry.path()).find("NOT BUILT in this version"), std::string::npos);
      EXPECT_FALSE(config.device.parameters.empty());
    }
    ++seen;
  }
  EXPECT_EQ(seen, expected.size());
}

TEST(ShippedConfigs, PaperValuesAreThePapers) {
  const DaemonConfig wall = load_config(config_dir / "loopback-linear-wall.toml");
  // Hulin section 7: m = 0.1 kg, T = 1 ms, d = 1, K = 0.09 m/T^2, B = 0.46 m/T.
  EXPECT_DOUBLE_EQ(wall.loop.period_s, 1e-3);
  EXPECT_EQ(*find(wall.device.parameters, "mass"), ParameterValue{0.1});
  // (The paper prints B = 4.6 N s/m; 0.46 m/T is 46 N s/m: see the file's note.)
  EXPECT_NEAR(std::get<double>(*find(wall.scene.parameters, "stiffness")), 0.09 * 0.1 / 1e-6, 1e-9);
  EXPECT_NEAR(std::get<double>(*find(wall.scene.parameters, "damping")), 0.46 * 0.1 / 1e-3, 1e-12);
  EXPECT_EQ(*find(wall.scene.parameters, "delay"), ParameterValue{1.0});

  const DaemonConfig two = load_config(config_dir / "loopback-two-mass.toml");
  // Diaz & Gil Table I.
  EXPECT_EQ(*find(two.device.parameters, "motor_mass"), ParameterValue{0.3});
  EXPECT_EQ(*find(two.device.parameters, "body_mass"), ParameterValue{5.1});
  EXPECT_EQ(*find(two.device.parameters, "motor_damping"), ParameterValue{0.1});
  EXPECT_EQ(*find(two.device.parameters, "body_damping"), ParameterValue{3.4});
  EXPECT_EQ(*find(two.device.parameters, "cable_stiffness"), ParameterValue{79.5e3});
  EXPECT_EQ(*find(two.device.parameters, "cable_damping"), ParameterValue{15.0});
}

}  // namespace
}  // namespace hapticd::daemon::config::examples_test
