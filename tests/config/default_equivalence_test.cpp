// A key a config file leaves out means what it means in the built-in
// default: one source of defaults (the loopback driver's), so a file that
// sets only [control] socket and [recorder] directory runs the same device
// model and gets the same stability verdict as `hapticd` without --config.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "daemon/config/config.hpp"
#include "daemon/device_factory.hpp"
#include "daemon/service.hpp"
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/loopback/loopback_device.hpp"

namespace hapticd::daemon::default_equivalence_test {
namespace {

namespace fs = std::filesystem;

fs::path scratch_dir() {
  const fs::path dir = fs::temp_directory_path() / ("hapticd-defaults-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

config::DaemonConfig minimal_config(const fs::path& dir) {
  return config::parse_config("[control]\nsocket = \"" + (dir / "s.sock").string() +
                                  "\"\n[recorder]\ndirectory = \"" + dir.string() + "\"\n",
                              "minimal.toml");
}

TEST(MinimalConfig, BuildsTheBuiltInDefaultsDevice) {
  const fs::path dir = scratch_dir();
  const BuiltDevice builtin = build_device(config::default_config());
  const BuiltDevice minimal = build_device(minimal_config(dir));
  // The loopback is a plugin like any driver: reach its config through its type.
  const auto* builtin_loopback = &builtin.device->hooks_as<drivers::loopback::LoopbackDevice>();
  const auto* minimal_loopback = &minimal.device->hooks_as<drivers::loopback::LoopbackDevice>();
  ASSERT_NE(builtin_loopback, nullptr);
  ASSERT_NE(minimal_loopback, nullptr);
  const auto& a = builtin_loopback->config();
  const auto& b = minimal_loopback->config();
  EXPECT_EQ(a.motion, b.motion);
  EXPECT_EQ(a.plant, b.plant);
  EXPECT_EQ(a.mass, b.mass);
  EXPECT_EQ(a.damping, b.damping);
  EXPECT_EQ(a.coulomb, b.coulomb);
  EXPECT_EQ(a.counts, b.counts);
  EXPECT_EQ(a.max_force, b.max_force);
  EXPECT_EQ(a.delay, b.delay);
  EXPECT_EQ(a.period_s, b.period_s);
  // The defaults are the driver's: the wheel has the bearing damping the
  // default scene needs (b > k T / 2).
  EXPECT_EQ(b.damping, drivers::loopback::LoopbackConfig::defaults(drivers::Motion::rotary).damping);
  EXPECT_GT(b.damping, 1.0186 * 1e-3 / 2);
  fs::remove_all(dir);
}

TEST(MinimalConfig, SameDeviceModelSceneAndVerdictAsTheBuiltInDefault) {
  const fs::path dir = scratch_dir();
  config::DaemonConfig builtin = config::default_config();
  builtin.control.socket = (dir / "s.sock").string();
  builtin.recorder.directory = dir.string();
  ServiceOptions with_builtin;
  with_builtin.config = builtin;
  ServiceOptions with_minimal;
  with_minimal.config = minimal_config(dir);
  // Before the fix the minimal file was refused here: "spring-wheel: unstable
  // on this device ... pole radius 1.000032577" (no bearing damping).
  std::string builtin_text;
  std::string minimal_text;
  ASSERT_NO_THROW(builtin_text = Service(with_builtin).describe());
  ASSERT_NO_THROW(minimal_text = Service(with_minimal).describe());
  EXPECT_EQ(minimal_text, builtin_text);
  EXPECT_NE(minimal_text.find("b = 0.002 N m s/rad"), std::string::npos) << minimal_text;
  EXPECT_NE(minimal_text.find("stability: stable on this device"), std::string::npos) << minimal_text;
  fs::remove_all(dir);
}

// config/hapticd.toml shows the loopback defaults it does not set as
// comments ("#   damping = 0.002 ..."): they must be the driver's.
TEST(ShippedDefaultConfig, CommentedLoopbackDefaultsAreTheDriversDefaults) {
  std::ifstream in(fs::path(HAPTICD_SOURCE_DIR) / "config" / "hapticd.toml");
  ASSERT_TRUE(in);
  const auto rotary = drivers::loopback::LoopbackConfig::defaults(drivers::Motion::rotary);
  int shown = 0;
  for (std::string line; std::getline(in, line);) {
    if (!line.starts_with("#   ")) continue;
    std::istringstream words(line.substr(4));
    std::string key;
    std::string equals;
    double value = 0.0;
    if (!(words >> key >> equals >> value) || equals != "=") continue;
    ++shown;
    if (key == "mass") {
      EXPECT_EQ(value, rotary.mass);
    } else if (key == "damping") {
      EXPECT_EQ(value, rotary.damping);
    } else if (key == "max_force") {
      EXPECT_EQ(value, rotary.max_force);
    } else {
      ADD_FAILURE() << "config/hapticd.toml shows a default this test does not check: " << line;
    }
  }
  EXPECT_EQ(shown, 3);
}

}  // namespace
}  // namespace hapticd::daemon::default_equivalence_test
