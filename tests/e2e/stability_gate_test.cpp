// End-to-end: no stability verdict from numbers that overflowed or lost
// precision, and no parameter outside its documented range, through the real
// binaries: `hapticctl analyze` (exit 1 with the reason when it cannot
// assess, 2 for a flag outside its range) and `hapticctl load` against a
// running hapticd (refused, naming the range).

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::stability_gate_test {
namespace {

using nlohmann::json;

std::string joined(const std::vector<std::string>& args) {
  std::string out;
  for (const auto& a : args) out += a + " ";
  return out;
}

std::size_t line_count(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += c == '\n' ? 1 : 0;
  if (!text.empty() && text.back() != '\n') ++n;
  return n;
}

CommandResult analyze(std::vector<std::string> args) {
  args.insert(args.begin(), "analyze");
  return run(hapticctl_binary(), args);
}

// Exit 1, one line on stderr that says it cannot assess and why; no "nan"
// anywhere, no "stable" verdict. With --json the object says cannot_assess.
void expect_cannot_assess(const std::vector<std::string>& args, const std::string& why) {
  const CommandResult human = analyze(args);
  EXPECT_EQ(human.exit_code, 1) << joined(args) << "\n" << human.out << human.err;
  EXPECT_EQ(line_count(human.err), 1u) << joined(args) << "\n" << human.err;
  EXPECT_NE(human.err.find("cannot assess"), std::string::npos) << joined(args) << "\n" << human.err;
  EXPECT_NE(human.err.find(why), std::string::npos) << joined(args) << "\n" << human.err;
  EXPECT_EQ(human.out.find("nan"), std::string::npos) << joined(args) << "\n" << human.out;
  EXPECT_EQ(human.out.find("verdict:             stable"), std::string::npos) << human.out;
  EXPECT_EQ(human.out.find("marginal"), std::string::npos) << joined(args) << "\n" << human.out;

  std::vector<std::string> with_json = args;
  with_json.push_back("--json");
  const CommandResult machine = analyze(with_json);
  EXPECT_EQ(machine.exit_code, 1) << joined(with_json) << "\n" << machine.err;
  const json out = json::parse(machine.out, nullptr, false);
  ASSERT_FALSE(out.is_discarded()) << machine.out;
  EXPECT_EQ(out.value("verdict", ""), "cannot_assess") << machine.out;
  EXPECT_NE(out.value("reason", "").find(why), std::string::npos) << machine.out;
  if (out.contains("stable")) {
    EXPECT_EQ(out["stable"], json(false)) << machine.out;
  }
  if (out.contains("marginal")) {
    EXPECT_EQ(out["marginal"], json(false)) << machine.out;
  }
}

// The attacker's inputs: a spring of 1e308 N m/rad under forward Euler
// overflows w_n^2 T; it used to read "stable, marginal, |lambda| = 0".
TEST(StabilityGate, AnalyzeIntegratorOverflowCannotAssess) {
  expect_cannot_assess({"integrator", "--scheme", "forward-euler", "--stiffness", "1e308", "--inertia",
                        "0.0258", "--period", "1ms"},
                       "k / J");
  expect_cannot_assess({"integrator", "--scheme", "rk4", "--stiffness", "1", "--inertia", "0.0258",
                        "--period", "1ms", "--damping", "1e308"},
                       "b / J");
}

// The exact ZOH of an undamped spring has |lambda| = 1; at w_n T = 6e7 the
// rounding of the matrix exponential (64 eps w_n T = 9e-7) is wider than the
// 1e-7 a verdict needs. It used to read "marginal".
TEST(StabilityGate, AnalyzeIntegratorPrecisionLossCannotAssess) {
  expect_cannot_assess(
      {"integrator", "--scheme", "exact", "--stiffness", "1e20", "--inertia", "0.0258", "--period", "1ms"},
      "w_n T");
  expect_cannot_assess(
      {"integrator", "--scheme", "exact", "--stiffness", "1e28", "--inertia", "0.0258", "--period", "1s"},
      "w_n T");
}

// A 1e308 kg motor mass overflowed k_c m in omega_n (printed -nan) and still
// gave "Q < K_CR: the cable mode limits the stiffness".
TEST(StabilityGate, AnalyzeTwoMassOverflowCannotAssess) {
  expect_cannot_assess(
      {"critical-stiffness", "--plant", "two-mass", "--period", "1ms", "--motor-mass", "1e308"}, "omega_n");
}

// A wall whose damping swamps the mass term of Hulin eq. (3): the roots say
// nothing about the device any more.
TEST(StabilityGate, AnalyzeWallPrecisionLossCannotAssess) {
  expect_cannot_assess({"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1", "--stiffness", "9000",
                        "--damping", "1e300"},
                       "mass term");
}

struct BadFlag {
  std::vector<std::string> args;
  std::string flag;
  std::string accepted;  ///< a piece of what the message must say is accepted
};

TEST(StabilityGate, AnalyzeFlagsOutsideTheirRangeAreUsageErrors) {
  const std::vector<std::string> spring{"integrator", "--scheme",  "exact", "--stiffness",
                                        "1",          "--inertia", "1"};
  auto with = [](std::vector<std::string> base, std::vector<std::string> more) {
    base.insert(base.end(), more.begin(), more.end());
    return base;
  };
  const std::vector<BadFlag> cases{
      // An empty --damping used to be silently 0.
      {with(spring, {"--period", "1ms", "--damping", ""}), "--damping", "auto"},
      {with(spring, {"--period", "1ms", "--damping", "nan"}), "--damping", "auto"},
      {with(spring, {"--period", "1ms", "--damping", "-1"}), "--damping", ">= 0"},
      // Periods are 1 us to 1 s: 1e308 used to exit 2 with "no phase crossover".
      {{"critical-stiffness", "--period", "1e308"}, "--period", "1 us to 1 s"},
      {{"critical-stiffness", "--period", "1e-300"}, "--period", "1 us to 1 s"},
      {with(spring, {"--period", "1e-300"}), "--period", "1 us to 1 s"},
      {with(spring, {"--period", "inf"}), "--period", "1 us to 1 s"},
      {with(spring, {"--period", "-1ms"}), "--period", "1 us to 1 s"},
      {with(spring, {"--period", "0"}), "--period", "1 us to 1 s"},
      {{"wall", "--mass", "0.1", "--period", "10s", "--delay", "1"}, "--period", "1 us to 1 s"},
      {{"integrator", "--scheme", "exact", "--stiffness", "inf", "--inertia", "1", "--period", "1ms"},
       "--stiffness",
       "finite"},
      {{"integrator", "--scheme", "exact", "--stiffness", "1", "--inertia", "-nan", "--period", "1ms"},
       "--inertia",
       "> 0"},
      {{"integrator", "--scheme", "exact", "--stiffness", "1", "--mass", "0", "--period", "1ms"},
       "--mass",
       "> 0"},
      {{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1", "--stiffness", "nan"},
       "--stiffness",
       ">= 0"},
      {{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1", "--damping", "-inf"},
       "--damping",
       ">= 0"},
      {{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1e9"}, "--delay", "0 to 64"},
      // Delays are 0 to 100 periods (the phase scan resolves them) and 0 to 1 s.
      {{"critical-stiffness", "--period", "1ms", "--delay", "1e300"}, "--delay", "100 periods"},
      {{"critical-stiffness", "--period", "1ms", "--delay", "101ms"}, "--delay", "100 periods"},
      {{"critical-stiffness", "--period", "1ms", "--delay", "nan"}, "--delay", "100 periods"},
      {{"critical-stiffness", "--period", "1ms", "--mass", "inf"}, "--mass", "> 0"},
      {{"critical-stiffness", "--period", "1ms", "--plant", "two-mass", "--cable-stiffness", "0"},
       "--cable-stiffness",
       "> 0"},
      {{"critical-stiffness", "--period", "1ms", "--plant", "two-mass", "--body-damping", "nan"},
       "--body-damping",
       ">= 0"},
      {{"boundary", "--delay", "1", "--points", "1e9"}, "--points", "2 to 100000"},
  };
  for (const auto& c : cases) {
    const CommandResult r = analyze(c.args);
    EXPECT_EQ(r.exit_code, 2) << joined(c.args) << "\n" << r.out << r.err;
    EXPECT_EQ(line_count(r.err), 1u) << joined(c.args) << "\n" << r.err;
    EXPECT_NE(r.err.find(c.flag), std::string::npos) << joined(c.args) << "\n" << r.err;
    EXPECT_NE(r.err.find(c.accepted), std::string::npos) << joined(c.args) << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << joined(c.args) << "\n" << r.out;
  }
}

// Valid input still gives a result with exit 0, stable or not.
TEST(StabilityGate, AnalyzeValidInputStillExitsZero) {
  for (const std::vector<std::string>& args : {
           std::vector<std::string>{"integrator", "--scheme", "forward-euler", "--stiffness", "1000",
                                    "--inertia", "0.01", "--period", "1ms"},
           std::vector<std::string>{"integrator", "--scheme", "exact", "--stiffness", "1e9", "--inertia",
                                    "1e-6", "--period", "10ms"},
           std::vector<std::string>{"critical-stiffness", "--period", "1s"},
           std::vector<std::string>{"critical-stiffness", "--period", "1us", "--delay", "100us"},
           std::vector<std::string>{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1", "--stiffness",
                                    "20000", "--damping", "46"},
       }) {
    const CommandResult r = analyze(args);
    EXPECT_EQ(r.exit_code, 0) << joined(args) << "\n" << r.err;
    EXPECT_EQ(r.out.find("nan"), std::string::npos) << joined(args) << "\n" << r.out;
  }
}

const char* const wheel_device = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 1.0

[device.loopback]
motion = "rotary"
damping = 0.002

[scene]
name = "free"
)";

const char* const linear_device = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 20.0

[device.loopback]
motion = "linear"
mass = 0.1

[scene]
name = "free"
)";

struct BadLoad {
  std::vector<std::string> args;
  std::string parameter;
  std::string range;
};

void expect_refused(const Daemon& d, const BadLoad& c) {
  const CommandResult r = d.ctl(c.args);
  EXPECT_EQ(r.exit_code, 1) << joined(c.args) << "\n" << r.out << r.err;
  EXPECT_NE(r.err.find(c.parameter + ":"), std::string::npos) << joined(c.args) << "\n" << r.err;
  EXPECT_NE(r.err.find(c.range), std::string::npos) << joined(c.args) << "\n" << r.err;
  EXPECT_EQ(r.err.find("force"), std::string::npos) << "a range is not forceable: " << r.err;
}

// `load spring-wheel damping=1e308 integrator=forward-euler` used to be
// accepted as "stable, pole radius 0.000000000" and produced NaN within a
// second; `wall damping=1e308` was accepted with radius 0.0125 and chattered.
TEST(StabilityGate, LoadRefusesParametersOutsideTheirRange) {
  TempDir wheel_dir;
  Daemon wheel(wheel_dir, wheel_device);
  ASSERT_TRUE(wheel.running()) << wheel.log();
  for (const BadLoad& c : std::vector<BadLoad>{
           {{"load", "spring-wheel", "damping=1e308", "integrator=forward-euler"}, "damping", "<= 1e+06"},
           {{"load", "spring-wheel", "damping=1e308", "integrator=forward-euler", "--force"},
            "damping",
            "<= 1e+06"},
           {{"load", "spring-wheel", "inertia=1e-300"}, "inertia", ">= 1e-09"},
           {{"load", "spring-wheel", "stiffness=1e10"}, "stiffness", "<= 1e+09"},
           {{"load", "relay", "amplitude=1e308"}, "amplitude", "<= 1e+06"},
       }) {
    expect_refused(wheel, c);
  }
  // In range, the verdict still comes from the analysis.
  const CommandResult ok = wheel.ctl({"load", "spring-wheel", "damping=auto", "integrator=forward-euler"});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  const CommandResult status = wheel.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  EXPECT_TRUE(json::parse(status.out)["fault"].is_null()) << status.out;
  EXPECT_EQ(wheel.stop(), 0) << wheel.log();

  TempDir wall_dir;
  Daemon wall(wall_dir, linear_device);
  ASSERT_TRUE(wall.running()) << wall.log();
  for (const BadLoad& c : std::vector<BadLoad>{
           {{"load", "wall", "damping=1e308"}, "damping", "<= 1e+06"},
           {{"load", "wall", "stiffness=1e308", "--force"}, "stiffness", "<= 1e+09"},
           {{"load", "wall", "position=1e300"}, "position", "1e+06"},
       }) {
    expect_refused(wall, c);
  }
  EXPECT_EQ(wall.ctl({"load", "wall", "stiffness=9000", "damping=46"}).exit_code, 0);
  EXPECT_EQ(wall.stop(), 0) << wall.log();
}

}  // namespace
}  // namespace hapticd::e2e::stability_gate_test
