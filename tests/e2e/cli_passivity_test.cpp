// End-to-end: `hapticctl analyze passivity` and the passivity boundary of
// `analyze boundary`, run as the real binary: the JSON contract, the closed
// forms (d = 0: K T/2 + B; B = 0: K T (d + 1/2)), exit codes.

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::cli_passivity_test {
namespace {

using nlohmann::json;

CommandResult hapticctl(std::vector<std::string> args) { return run(hapticctl_binary(), args); }

json passivity(std::vector<std::string> args) {
  args.insert(args.begin(), {"analyze", "passivity"});
  args.push_back("--json");
  const CommandResult r = hapticctl(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

TEST(CliPassivity, WallClosedFormsAndKeys) {
  const json d0 = passivity({"--stiffness", "9000", "--damping", "46", "--period", "1ms", "--delay", "0",
                             "--device-damping", "60"});
  for (const char* key : {"required_damping", "frequency_hz", "passive", "max_stiffness", "state", "reason"})
    EXPECT_TRUE(d0.contains(key)) << key << " in " << d0.dump();
  EXPECT_NEAR(d0["required_damping"].get<double>(), 9000 * 1e-3 / 2 + 46, 1e-9);
  EXPECT_NEAR(d0["frequency_hz"].get<double>(), 500.0, 1e-6);
  EXPECT_TRUE(d0["passive"].get<bool>());
  EXPECT_NEAR(d0["max_stiffness"].get<double>(), 2 * (60 - 46) / 1e-3, 1e-6);
  EXPECT_EQ(d0["state"], "bounded");
  EXPECT_TRUE(d0["reason"].is_null());

  const json d3 = passivity({"--stiffness", "9000", "--damping", "0", "--period", "1ms", "--delay", "3"});
  EXPECT_NEAR(d3["required_damping"].get<double>(), 9000 * 1e-3 * 3.5, 1e-9);
  EXPECT_TRUE(d3["at_zero_frequency_limit"].get<bool>());
  EXPECT_FALSE(d3.contains("passive"));  // no --device-damping, no device answers

  // Hulin section 7: stable, but it needs 50.72 N s/m; with B = 46 nothing is passive on 2 N s/m.
  const json hulin = passivity({"--stiffness", "9000", "--damping", "46", "--period", "1000us", "--delay",
                                "1", "--device-damping", "2"});
  EXPECT_NEAR(hulin["required_damping"].get<double>(), 50.5 + 81.0 / 368.0, 1e-9);
  EXPECT_FALSE(hulin["passive"].get<bool>());
  EXPECT_EQ(hulin["max_stiffness"].get<double>(), 0.0);
}

TEST(CliPassivity, SpringsAndTheUndampedWheel) {
  const double k = 0.8 / (M_PI / 4.0), j = k / (4.0 * M_PI * M_PI);
  const json undamped =
      passivity({"--scene", "spring-wheel", "--stiffness", std::to_string(k), "--inertia", std::to_string(j),
                 "--damping", "0", "--period", "1ms", "--delay", "0", "--device-damping", "1"});
  EXPECT_EQ(undamped["state"], "unbounded");
  EXPECT_TRUE(undamped["required_damping"].is_null());
  EXPECT_FALSE(undamped["passive_at_any_damping"].get<bool>());
  EXPECT_FALSE(undamped["passive"].get<bool>());
  EXPECT_NEAR(undamped["frequency_hz"].get<double>(), 1.0, 1e-5);
  EXPECT_NE(undamped["reason"].get<std::string>().find("undamped mode at 1 Hz"), std::string::npos);
  EXPECT_EQ(undamped["damping_unit"], "N m s/rad");

  const json damped = passivity({"--scene", "spring-mass", "--stiffness", "79", "--mass", "0.5", "--damping",
                                 "2", "--period", "1ms", "--delay", "1", "--device-damping", "3"});
  EXPECT_EQ(damped["state"], "bounded");
  EXPECT_GT(damped["required_damping"].get<double>(), 2.0);  // at least the damper's own Nyquist term
  EXPECT_GT(damped["max_stiffness"].get<double>(), 0.0);
  EXPECT_EQ(damped["integrator"], "exact");
  EXPECT_EQ(damped["damping_reference"], "relative");
}

TEST(CliPassivity, HumanFormSaysTheSame) {
  const CommandResult r = hapticctl({"analyze", "passivity", "--stiffness", "9000", "--damping", "46",
                                     "--period", "1ms", "--delay", "1", "--device-damping", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("required damping"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("50.7201 N s/m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("NOT PASSIVE"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("largest passive stiffness"), std::string::npos) << r.out;
}

TEST(CliPassivity, BadUsageExitsTwo) {
  const std::vector<std::vector<std::string>> cases{
      {"--stiffness", "-1", "--damping", "46", "--period", "1ms", "--delay", "1"},
      {"--stiffness", "nan", "--damping", "46", "--period", "1ms", "--delay", "1"},
      {"--stiffness", "9000", "--damping", "46", "--period", "0", "--delay", "1"},
      {"--stiffness", "9000", "--damping", "46", "--period", "1ms", "--delay", "65"},
      {"--stiffness", "9000", "--damping", "46", "--period", "1ms", "--delay", "1", "--device-damping",
       "inf"},
      {"--stiffness", "9000", "--damping", "46", "--period", "1ms", "--delay", "1", "--inertia", "1"},
      {"--scene", "spring-mass", "--stiffness", "9", "--damping", "0", "--period", "1ms", "--delay", "0"},
      {"--scene", "relay", "--stiffness", "9", "--damping", "0", "--period", "1ms", "--delay", "0"},
  };
  for (auto args : cases) {
    args.insert(args.begin(), {"analyze", "passivity"});
    const CommandResult r = hapticctl(args);
    EXPECT_EQ(r.exit_code, 2) << args[2] << " " << args[3] << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
  }
}

TEST(CliPassivity, OverflowCannotBeAssessedExitsOne) {
  const CommandResult r = hapticctl({"analyze", "passivity", "--stiffness", "1e308", "--damping", "0",
                                     "--period", "1s", "--delay", "3", "--json"});
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot assess: the required damping overflowed to inf"), std::string::npos) << r.err;
  const json out = json::parse(r.out);
  EXPECT_EQ(out["state"], "cannot_assess");
  EXPECT_TRUE(out["required_damping"].is_null());
}

TEST(CliPassivity, BoundaryCarriesThePassivityCurve) {
  const CommandResult r = hapticctl({"analyze", "boundary", "--delay", "1", "--points", "20",
                                     "--device-damping", "2", "--mass", "0.1", "--period", "1ms", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json out = json::parse(r.out);
  ASSERT_EQ(out["points"].size(), 20u);  // Hulin's curve, unchanged
  const json& p = out["passivity"];
  EXPECT_NEAR(p["device_beta"].get<double>(), 0.02, 1e-15);
  ASSERT_EQ(p["points"].size(), 20u);
  EXPECT_EQ(p["points"][0][0].get<double>(), 0.0);
  EXPECT_NEAR(p["points"][0][1].get<double>(), 2 * 0.02 / 3, 1e-15);  // 2 b T/m / (2d + 1)
  EXPECT_NEAR(p["points"][19][0].get<double>(), 0.02, 1e-15);
  EXPECT_EQ(p["points"][19][1].get<double>(), 0.0);

  const CommandResult without =
      hapticctl({"analyze", "boundary", "--delay", "1", "--points", "20", "--json"});
  EXPECT_FALSE(json::parse(without.out).contains("passivity"));
  const CommandResult partial = hapticctl({"analyze", "boundary", "--delay", "1", "--device-damping", "2"});
  EXPECT_EQ(partial.exit_code, 2);
  EXPECT_NE(partial.err.find("--device-damping, --mass and --period together"), std::string::npos);
}

}  // namespace
}  // namespace hapticd::e2e::cli_passivity_test
