// CiA 402 homing end to end (issue 23, item 4): the real hapticd with
// driver = "canopen" and homing = "cia402" against the simulated drive as
// its own process (hapticd-devsim canopen --limit-switches), driven by the
// real hapticctl.
//   - method 17 (the negative limit switch): the drive moves to the switch
//     and back off it in mode 6 before the loop, comes back in cyclic
//     synchronous torque, and the loop's positions are measured from the
//     home (which reads -home_offset); status says "homed with method 17";
//   - method 37 (the current position) with origin = "persist": the homed
//     frame is kept; a restart with homing = "none" against the same drive,
//     which kept power, restores it, and the positions read on as before;
//   - a method the drive does not have stops hapticd at start-up with the
//     drive's refusal at the homing_method key's file:line:column.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "tests/drivers/canopen/e2e/drive_process.hpp"
#include "tests/e2e/support.hpp"

namespace hapticd::e2e::homing_e2e_test {
namespace canopen_homing {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

const std::vector<std::string> limit_switches = {"--limit-switches", "-0.5,0.5"};
constexpr double count = 2.0 * 3.141592653589793 / 16384.0;  // rad per 0x6064 increment

std::string config(const std::string& interface, const std::string& homing) {
  return "[loop]\nperiod = \"1ms\"\noverrun_limit = 0\n[device]\ndriver = \"canopen\"\ntorque_limit = 1.0\n"
         "origin = \"persist\"\norigin_file = \"origin.toml\"\n"
         "[device.canopen]\ninterface = \"" +
         interface +
         "\"\ncounts_per_unit = 16384\nmass = 0.01\ndamping = 0.002\ntpdo_timeout_periods = 1000\n"
         "heartbeat_timeout = \"1s\"\nsdo_timeout = \"1s\"\n" +
         homing +
         "[scene]\nname = \"spring-wheel\"\nstiffness = 1.0186\ninertia = 0.0258\nintegrator = \"exact\"\n"
         "damping = \"auto\"\n";
}

json status_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return r.exit_code == 0 ? json::parse(r.out) : json::object();
}

template <class Condition>
bool eventually(Condition&& condition, std::chrono::milliseconds limit = 20s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(10ms);
  }
  return condition();
}

bool past_cycle(const Daemon& d, double cycle) {
  const json s = status_of(d);
  return s.contains("cycle") && s["cycle"].get<double>() > cycle;
}

std::string text_of(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

TEST(CanopenHoming, OnTheNegativeLimitSwitchBeforeTheLoopThenTorqueModeFromTheHome) {
  TempDir dir;
  SimulatedDrive drive(dir, "mode=free", rigid_wheel_plant, limit_switches);
  const std::string homing =
      "homing = \"cia402\"\nhoming_method = 17\nhome_offset = 0.25\nhoming_speed_switch = 1.0\n"
      "homing_speed_zero = 0.2\nhoming_acceleration = 10.0\nhoming_timeout = \"10s\"\n";
  Daemon d(dir, config(drive.interface(), homing), {"--record", "run.csv"});
  ASSERT_TRUE(eventually([&] { return past_cycle(d, 500); })) << d.log() << drive.log();
  const json c = status_of(d)["calibration"];
  EXPECT_EQ(c["how"], "homed") << c.dump();
  EXPECT_EQ(c["homing_method"], 17);
  EXPECT_EQ(c["origin"], 0.0) << "the drive's own position is measured from the home";
  const auto periods = c.value("homing_periods", 0u);
  EXPECT_GT(periods, 500u) << "0.5 rad to the switch at 1 rad/s";
  EXPECT_LT(periods, 5000u);
  EXPECT_NE(d.ctl({"status"})
                .out.find("calibration: homed: CiA 402 homing method 17 (on the negative limit switch)"),
            std::string::npos);
  const auto mode = d.ctl({"device", "sdo", "read", "0x6061", "0", "--json"});
  ASSERT_EQ(mode.exit_code, 0) << mode.err;
  EXPECT_EQ(json::parse(mode.out)["value"], 10) << "cyclic synchronous torque for the loop";
  EXPECT_NE(text_of(dir.path / "origin.toml").find("set_by = \"homing\"\nhoming_method = 17"),
            std::string::npos);
  EXPECT_EQ(d.stop(), 0) << d.log();
  std::cout << "homing on the negative limit switch through hapticd: " << periods << " periods of 1 ms\n";

  const Recording rec = read_recording(dir.path / "run.csv");
  ASSERT_FALSE(rec.rows.empty());
  // The home is the switch's edge, 0.5 rad below where the drive powered up;
  // it reads -home_offset, and the wheel stopped just past it, at rest.
  const double first = rec.values("position_rad").front();
  EXPECT_GT(first, -0.25 - count);
  EXPECT_LT(first, -0.25 + 0.05) << "at rest just off the switch";
  for (const double f : rec.values("flags"))
    EXPECT_EQ(static_cast<unsigned>(f) & 33u, 0u) << "no fault, no jump";
  bool noted = false;
  for (const auto& line : rec.comments)
    noted = noted || line.find("# note: calibration: homed: CiA 402 homing method 17") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(CanopenHoming, AHomedFrameIsRestoredAfterARestartWhileTheDriveKeptPower) {
  TempDir dir;
  SimulatedDrive drive(dir, "mode=hold trajectory=constant position=0.4", rigid_wheel_plant, limit_switches);
  double homed_position = 0.0;
  {
    Daemon d(dir, config(drive.interface(), "homing = \"cia402\"\nhoming_method = 37\nhome_offset = 0.1\n"),
             {"--record", "homed.csv"});
    ASSERT_TRUE(eventually([&] { return past_cycle(d, 300); })) << d.log() << drive.log();
    const json s = status_of(d);
    EXPECT_EQ(s["calibration"]["how"], "homed");
    EXPECT_LT(s["calibration"].value("homing_periods", 1000u), 50u) << "no motion: at once";
    homed_position = s["last"]["position"];
    EXPECT_NEAR(homed_position, -0.1, count) << "the home (where the hand holds it) reads -home_offset";
    EXPECT_EQ(d.stop(), 0);
  }
  // The drive's process kept running (kept power): its homed 0x6064 stands.
  Daemon d(dir, config(drive.interface(), "homing = \"none\"\n"), {"--record", "restored.csv"});
  ASSERT_TRUE(eventually([&] { return past_cycle(d, 300); })) << d.log() << drive.log();
  const json s = status_of(d);
  EXPECT_EQ(s["calibration"]["how"], "restored") << s["calibration"].dump();
  EXPECT_NE(s["calibration"]["summary"].get<std::string>().find("homed with method 37"), std::string::npos);
  EXPECT_NEAR(s["last"]["position"].get<double>(), homed_position, count) << "the same frame";
  EXPECT_EQ(d.stop(), 0);
}

TEST(CanopenHoming, AMethodTheDriveDoesNotHaveStopsTheStartAtTheKey) {
  TempDir dir;
  SimulatedDrive drive(dir, "mode=free");  // no limit switches: no method 17 either
  Daemon d(dir, config(drive.interface(), "homing = \"cia402\"\nhoming_method = 17\n"));
  EXPECT_EQ(d.wait(30s), 1) << d.log();
  const std::string log = d.log();
  EXPECT_NE(log.find("hapticd.toml:18:17: SDO write 0x6098:00 = 17 to node 1: aborted 0x06090030"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("CiA 402 0x6098 homing method 17 (on the negative limit switch) (homing_method)"),
            std::string::npos)
      << log;
}

}  // namespace
}  // namespace canopen_homing
}  // namespace hapticd::e2e::homing_e2e_test
