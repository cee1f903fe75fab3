// Calibration end to end on the loopback (issue 23, item 4): the real
// hapticd, driven by the real hapticctl.
//   - `hapticctl device zero` while a hand holds the wheel away from where it
//     powered up and torque flows: every position after it, in the recording
//     and in status, is the device's minus the origin; the scene restarts at
//     equilibrium there (no torque step, no encoder-jump fault); the
//     recording starts a section that says so; status says how it is
//     calibrated; with [device] origin = "persist" a restart restores it
//     (with "session" it does not);
//   - [device] require_calibration: the output stays zero (flag 128) and
//     status and scene.load say why, until the device is zeroed;
//   - a stale or corrupt origin file is refused at start-up with the reason,
//     and the daemon runs uncalibrated; a zero without a valid reading is refused.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "support.hpp"

namespace hapticd::e2e::calibration_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

// The hand turns the wheel steadily at 1 rad/s from where it powered up
// (an incremental encoder's zero): the 1 Hz virtual wheel trails it, so
// torque flows whenever device.zero comes, and builds up again after it.
const std::string hand = "mode=hold trajectory=ramp rate=1 from=0 to=1000";
constexpr double hand_rate = 1.0;  // rad/s
constexpr double period_s = 1e-3;

/// Where the hand holds the wheel in the row of loop cycle n (the device's own position).
double hand_at(double cycle) { return hand_rate * period_s * cycle; }
constexpr unsigned flag_fault = 1, flag_jump = 32, flag_uncalibrated = 128;

std::string config(const std::string& device_keys) {
  return "[loop]\noverrun_limit = 0\n[device]\ndriver = \"loopback\"\n" + device_keys +
         "[device.loopback]\nhand = \"" + hand +
         "\"\n[scene]\nname = \"spring-wheel\"\nintegrator = \"exact\"\ndamping = \"auto\"\n";
}

json status_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return r.exit_code == 0 ? json::parse(r.out) : json::object();
}

template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout = 20s) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

bool past_cycle(const Daemon& d, double cycle) {
  const json s = status_of(d);
  return s.contains("cycle") && s["cycle"].get<double>() > cycle;
}

std::size_t row_of_cycle(const Recording& rec, std::uint64_t cycle) {
  const auto cycles = rec.values("cycle");
  for (std::size_t i = 0; i < cycles.size(); ++i)
    if (static_cast<std::uint64_t>(cycles[i]) == cycle) return i;
  return cycles.size();
}

bool has_comment(const Recording& rec, const std::string& text) {
  for (const auto& c : rec.comments)
    if (c.find(text) != std::string::npos) return true;
  return false;
}

/// Zeroes the running daemon once the hand has turned the wheel and torque flows;
/// returns device.zero's result.
json zero_when_torque_flows(const Daemon& d) {
  EXPECT_TRUE(eventually([&] {
    const json s = status_of(d);
    return past_cycle(d, 1200) && std::abs(s["last"].value("applied", 0.0)) > 0.05;
  })) << d.log();
  const auto zero = d.ctl({"device", "zero", "--json"});
  EXPECT_EQ(zero.exit_code, 0) << zero.err;
  return zero.exit_code == 0 ? json::parse(zero.out) : json::object();
}

TEST(Calibration, ZeroShiftsEveryPositionWithoutATorqueStepAndARestartRestoresIt) {
  TempDir dir;
  const std::string keys = "origin = \"persist\"\norigin_file = \"origin.toml\"\n";
  json zero;
  {
    Daemon d(dir, config(keys), {"--record", "run.csv"});
    ASSERT_TRUE(d.running()) << d.log();
    EXPECT_EQ(status_of(d)["calibration"]["how"], "none");
    zero = zero_when_torque_flows(d);
    ASSERT_TRUE(zero.contains("cycle")) << zero.dump();
    const json c = status_of(d)["calibration"];
    EXPECT_EQ(c["how"], "zeroed");
    EXPECT_EQ(c["calibrated"], true);
    EXPECT_EQ(c["cycle"], zero["cycle"]);
    EXPECT_EQ(c["origin"], zero["origin"]);
    EXPECT_EQ(zero["kept"], (dir.path / "origin.toml").string());
    const auto human = d.ctl({"status"}).out;
    EXPECT_NE(
        human.find("calibration: zeroed at cycle " + std::to_string(zero["cycle"].get<std::uint64_t>())),
        std::string::npos)
        << human;
    ASSERT_TRUE(past_cycle(d, 0) &&
                eventually([&] { return past_cycle(d, zero["cycle"].get<double>() + 500); }));
    EXPECT_EQ(d.stop(), 0) << d.log();
  }
  const std::uint64_t at = zero["cycle"];
  const double origin = zero["origin"];
  EXPECT_NEAR(origin, hand_at(static_cast<double>(at)), 2e-3) << "the device's position then";
  const Recording rec = read_recording(dir.path / "run.csv");
  const auto position = rec.values("position_rad"), applied = rec.values("applied_n_m");
  const auto flags = rec.values("flags"), cycles = rec.values("cycle");
  const std::size_t i = row_of_cycle(rec, at);
  ASSERT_GT(i, 0u);
  ASSERT_LT(i + 400, position.size());
  // The 1 Hz wheel swings about its lag: device.zero may land near a zero
  // crossing (it did under ASan), so "flowed" is judged over the 300 ms before.
  double flowed = 0.0;
  for (std::size_t k = i > 300 ? i - 300 : 0; k < i; ++k) flowed = std::max(flowed, std::abs(applied[k]));
  EXPECT_GT(flowed, 0.05) << "torque flowed just before the zero";
  EXPECT_LT(std::abs(applied[i]), 1e-9) << "the scene restarted at equilibrium: no torque step";
  EXPECT_EQ(position[i], 0.0) << "the cycle it took effect in reads zero";
  for (std::size_t k = 0; k < i; ++k) EXPECT_NEAR(position[k], hand_at(cycles[k]), 2e-3) << "row " << k;
  for (std::size_t k = i; k < position.size(); ++k) {
    EXPECT_NEAR(position[k], hand_at(cycles[k]) - origin, 2e-3)
        << "row " << k << ": the device's position minus the origin";
  }
  for (std::size_t k = 0; k < flags.size(); ++k) {
    EXPECT_EQ(static_cast<unsigned>(flags[k]) & (flag_fault | flag_jump), 0u) << "row " << k;
  }
  EXPECT_GT(std::abs(applied[i + 300]), 1e-4) << "the scene renders on from the new origin";
  EXPECT_TRUE(has_comment(rec, "# section 2: origin set by device.zero at cycle " + std::to_string(at)));
  EXPECT_TRUE(has_comment(rec, "# note: calibration: zeroed at cycle " + std::to_string(at)));
  EXPECT_FALSE(has_comment(rec, "128 uncalibrated")) << "not required: the flags line as before";

  // A restart restores it: the device reads from the same origin.
  {
    Daemon d(dir, config(keys), {"--record", "again.csv"});
    ASSERT_TRUE(d.running()) << d.log();
    const json c = status_of(d)["calibration"];
    EXPECT_EQ(c["how"], "restored");
    EXPECT_EQ(c["origin"], origin);
    EXPECT_EQ(c["cycle"], at);
    EXPECT_NE(
        c["summary"].get<std::string>().find("incremental encoder: valid only if the device kept power"),
        std::string::npos)
        << c.dump();
    ASSERT_TRUE(eventually([&] { return past_cycle(d, 300); }));
    EXPECT_EQ(d.stop(), 0);
  }
  const Recording again = read_recording(dir.path / "again.csv");
  ASSERT_FALSE(again.rows.empty());
  EXPECT_NEAR(again.values("position_rad").front(), hand_at(again.values("cycle").front()) - origin, 2e-3)
      << "restored from the first cycle";
  EXPECT_TRUE(
      has_comment(again, "# note: calibration: restored from " + (dir.path / "origin.toml").string()));

  // origin = "session": the same file is not read; the device starts uncalibrated.
  Daemon d(dir, config("origin = \"session\"\norigin_file = \"origin.toml\"\n"));
  ASSERT_TRUE(d.running()) << d.log();
  EXPECT_EQ(status_of(d)["calibration"]["how"], "none");
  EXPECT_EQ(status_of(d)["calibration"]["keeping"], "session");
}

TEST(Calibration, RequiredCalibrationHoldsTheOutputAtZeroAndSaysWhyUntilZeroed) {
  TempDir dir;
  Daemon d(dir, config("require_calibration = true\n"), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return past_cycle(d, 1200); }));
  json c = status_of(d)["calibration"];
  EXPECT_EQ(c["output_held"], true);
  EXPECT_EQ(c["required"], true);
  const auto human = d.ctl({"status"}).out;
  EXPECT_NE(human.find("output held at zero: not calibrated"), std::string::npos) << human;
  const auto load = d.ctl({"load", "spring-wheel", "integrator=exact", "damping=auto", "--json"});
  ASSERT_EQ(load.exit_code, 0) << load.err;
  EXPECT_NE(load.out.find("the output stays zero until the device is calibrated"), std::string::npos)
      << load.out;
  const json zero = d.ctl({"device", "zero", "--json"}).exit_code == 0 ? status_of(d)["calibration"] : json();
  EXPECT_EQ(zero["how"], "zeroed");
  EXPECT_EQ(zero["output_held"], false);
  ASSERT_TRUE(eventually([&] { return past_cycle(d, zero["cycle"].get<double>() + 400); }));
  EXPECT_EQ(d.stop(), 0);

  const Recording rec = read_recording(dir.path / "run.csv");
  const auto applied = rec.values("applied_n_m"), flags = rec.values("flags");
  const std::size_t i = row_of_cycle(rec, zero["cycle"].get<std::uint64_t>());
  ASSERT_LT(i + 300, applied.size());
  for (std::size_t k = 0; k < i; ++k) {
    EXPECT_EQ(applied[k], 0.0) << "row " << k;
    EXPECT_NE(static_cast<unsigned>(flags[k]) & flag_uncalibrated, 0u) << "row " << k;
  }
  for (std::size_t k = i; k < applied.size(); ++k)
    EXPECT_EQ(static_cast<unsigned>(flags[k]) & flag_uncalibrated, 0u) << "row " << k;
  double peak = 0.0;
  for (std::size_t k = i; k < applied.size(); ++k) peak = std::max(peak, std::abs(applied[k]));
  EXPECT_GT(peak, 1e-4) << "renders once zeroed";
  EXPECT_TRUE(has_comment(rec, "64 stale_position, 128 uncalibrated"));
}

TEST(Calibration, AStaleOrCorruptOriginFileIsRefusedWithTheReasonAndTheDaemonRunsUncalibrated) {
  TempDir dir;
  const std::string keys = "origin = \"persist\"\norigin_file = \"origin.toml\"\n";
  std::ofstream(dir.path / "origin.toml")
      << "[origin]\nposition = \"twelve\"\nunit = \"rad\"\nset_by = \"zero\"\ncycle = 5\nset_at = \"now\"\n"
         "[identity]\ndriver = \"loopback\"\ndevice = \"rotary, rigid\"\nencoder = \"incremental\"\n"
         "motion = \"rotary\"\nresolution = 0.0003834951969714103\n";
  {
    Daemon d(dir, config(keys));
    ASSERT_TRUE(d.running()) << d.log();
    const json c = status_of(d)["calibration"];
    EXPECT_EQ(c["how"], "none");
    const std::string note = c["note"].is_string() ? c["note"].get<std::string>() : "";
    EXPECT_NE(note.find("origin.toml:2:12: origin.position = \"twelve\" is not accepted"), std::string::npos)
        << c.dump();
    EXPECT_NE(d.log().find("not restored"), std::string::npos) << d.log();
    // A zero replaces the bad file with a good one.
    ASSERT_TRUE(eventually([&] { return past_cycle(d, 100); }));
    ASSERT_EQ(d.ctl({"device", "zero"}).exit_code, 0);
    EXPECT_EQ(d.stop(), 0);
  }
  // Another encoder: the stored origin is refused, naming what differs.
  Daemon d(dir, config(keys + "encoder = \"absolute\"\n"));
  ASSERT_TRUE(d.running()) << d.log();
  const json c = status_of(d)["calibration"];
  EXPECT_EQ(c["how"], "none");
  EXPECT_NE(
      c["note"].get<std::string>().find("written for encoder \"incremental\", this device has \"absolute\""),
      std::string::npos)
      << c.dump();
}

TEST(Calibration, AZeroWithoutAValidPositionIsRefusedAndBadParamsAreNamed) {
  TempDir dir;
  Daemon d(dir, config(""));
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return past_cycle(d, 100); }));
  const auto extra = d.ctl({"device", "call", "device.zero", "x=1"});
  EXPECT_EQ(extra.exit_code, 1);
  EXPECT_NE(extra.err.find("device.zero: unknown member 'x'"), std::string::npos) << extra.err;
  ASSERT_EQ(d.ctl({"fault", "inject", "read-error"}).exit_code, 0);
  const auto refused = d.ctl({"device", "zero"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("the device gave no valid position within 2 s"), std::string::npos)
      << refused.err;
  EXPECT_EQ(status_of(d)["calibration"]["how"], "none") << "the origin is unchanged";
}

}  // namespace
}  // namespace hapticd::e2e::calibration_test
