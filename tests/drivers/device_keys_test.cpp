// The keys every device takes (motion, mass, damping) are declared once, in
// drivers/parameter.cpp, and every driver that uses the builders describes
// them alike: same type, unit, choices and range, whatever its help says.

#include <string>

#include <gtest/gtest.h>

#include "drivers/parameter.hpp"
#include "drivers/registry.hpp"

namespace hapticd::drivers::device_keys_test {
namespace {

const ParameterSpec* find(const DriverDescription& driver, const std::string& name) {
  for (const auto& p : driver.parameters) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

void expect_same_kind(const ParameterSpec& given, const ParameterSpec& common, const std::string& driver) {
  EXPECT_EQ(given.type, common.type) << driver << "." << common.name;
  EXPECT_EQ(given.unit, common.unit) << driver << "." << common.name;
  EXPECT_EQ(given.accepted, common.accepted) << driver << "." << common.name;
  EXPECT_EQ(given.minimum, common.minimum) << driver << "." << common.name;
  EXPECT_EQ(given.minimum_exclusive, common.minimum_exclusive) << driver << "." << common.name;
  EXPECT_EQ(given.maximum, common.maximum) << driver << "." << common.name;
}

TEST(DeviceKeys, EveryDriverDescribesMotionMassAndDampingAlike) {
  for (const auto& driver : driver_registry()) {
    // usb-hid keeps its own key list until the lifecycle refactor (issue
    // 19, items 1-2) gives every driver the same file roles.
    if (driver.name == "usb-hid") continue;
    for (const ParameterSpec& common : {motion_parameter(), mass_parameter(), damping_parameter()}) {
      const ParameterSpec* given = find(driver, common.name);
      ASSERT_NE(given, nullptr) << driver.name << " has no " << common.name;
      expect_same_kind(*given, common, driver.name);
    }
  }
}

TEST(DeviceKeys, TheCommonKeysTakeTheScenesRanges) {
  const ParameterSpec mass = mass_parameter();
  EXPECT_EQ(mass.minimum, world::parameter_range::min_mass);
  EXPECT_EQ(mass.maximum, world::parameter_range::max_mass);
  EXPECT_FALSE(mass.default_value.has_value());  // the device cannot know it: the config says it
  const ParameterSpec damping = damping_parameter();
  EXPECT_EQ(damping.maximum, world::parameter_range::max_damping);
  EXPECT_EQ(std::get<double>(*damping.default_value), 0.0);
  EXPECT_EQ(std::get<std::string>(*motion_parameter().default_value), "rotary");
}

// A word a number takes ("auto") and a choice's aliases work for a driver's
// keys as for a scene's: one ParameterSpec, one meaning.
TEST(DeviceKeys, WordsAndAliasesOfTheSharedSpec) {
  const std::vector<ParameterSpec> specs{
      ParameterSpec::number("gain", "", "a gain").defaults_to(1.0).at_least(0.0).or_word("auto"),
      ParameterSpec::choice("mode", {"fast", "slow"}, "a mode")
          .defaults_to("fast")
          .canonical_by([](std::string_view s) -> std::optional<std::string> {
            if (s == "quick" || s == "fast") return std::string("fast");
            if (s == "slow") return std::string("slow");
            return std::nullopt;
          })};
  const DriverParameters p("test", specs, {{"gain", std::string("auto")}, {"mode", std::string("quick")}});
  EXPECT_EQ(p.text("mode"), "fast");
  EXPECT_EQ(p.to_json()["gain"], "auto");
  EXPECT_EQ(accepted_text(specs[0]), "a number >= 0 or auto");
  EXPECT_THROW(DriverParameters("test", specs, {{"mode", std::string("medium")}}), ParameterError);
}

}  // namespace
}  // namespace hapticd::drivers::device_keys_test
