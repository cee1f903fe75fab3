// The canopen driver end to end: the real hapticd with `driver = "canopen"`
// against the simulated CiA 402 drive running as its own process
// (hapticd-devsim canopen, on the unix seam), driven by the real hapticctl.
//   - the 45-degree step on spring-wheel matches the loopback run of the same
//     plant with one period of device delay, within 1 % of the peak;
//   - an EMCY, missing TPDOs and a killed drive each zero the output in the
//     period they are seen and show the drive's reason in `hapticctl status`;
//     `fault clear` recovers without a torque step;
//   - TPDOs missing below tpdo_timeout_periods leave the last position,
//     rendered without a fault and flagged stale_position in the recording;
//   - a drive that stops answering (its heartbeat lost) zeroes and latches
//     with the drive's reason, and `fault clear` re-enables it through the
//     CiA 402 state machine once it answers again;
//   - hapticctl device sdo reads and writes objects of the running drive,
//     refusing the mapping while enabled and decoding the drive's aborts;
//   - while enabled it refuses every object that scales or bounds the torque
//     (0x6076, 0x6072, 0x1029 ...) with the object's role, as a -32000 error;
//   - a killed hapticd lets the drive's heartbeat consumer disable it.
// The canopen runs use the real clock (the drive answers in its own process);
// the loopback reference runs on the virtual clock.

#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/drivers/canopen/e2e/drive_process.hpp"
#include "tests/e2e/support.hpp"

namespace hapticd::e2e::canopen_e2e_test {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

const std::string step_hand = "mode=hold trajectory=step amplitude=0.785398163397448 at=0.5";
// The hand lets go after 0.5 s of hold: the wheel then swings on the virtual
// spring through the device, so the device's delay shows in the torque.
const std::string releasing_hand = step_hand + " release_at=1.0";
// A hand that keeps turning the wheel, so torque flows again after each clear.
const std::string turning_hand = "mode=hold trajectory=sine amplitude=0.3 frequency=1";
const std::string scene =
    "[scene]\nname = \"spring-wheel\"\nstiffness = 1.0186\ninertia = 0.0258\nintegrator = \"exact\"\n"
    "damping = \"auto\"\n";

/// heartbeat_timeout: both ways (the drive's 0x1016 on hapticd, hapticd on the
/// drive's 0x1017). 1 s unless the test is about it: on this shared VM at load
/// 10 a drive process went unscheduled for 100 ms, and once for 500 ms (so
/// the SDO timeout of the configuration is 1 s too, not the default 100 ms).
std::string canopen_config(const std::string& interface, const std::string& loop, int tpdo_timeout,
                           const std::string& heartbeat_timeout = "1s") {
  // overrun_limit = 0: this VM stalls the loop for tens of ms now and then.
  return "[loop]\nperiod = \"1ms\"\noverrun_limit = 0\n" + loop +
         "[device]\ndriver = \"canopen\"\ntorque_limit = 1.0\n"
         "[device.canopen]\ninterface = \"" +
         interface + "\"\ncounts_per_unit = 16384\nmass = 0.01\ndamping = 0.002\ntpdo_timeout_periods = " +
         std::to_string(tpdo_timeout) + "\nheartbeat_timeout = \"" + heartbeat_timeout +
         "\"\nsdo_timeout = \"1s\"\n" + scene;
}

std::string loopback_config(const std::string& hand, int delay) {
  // Appended, not "text" + std::to_string(): GCC 12 at -O3 warns
  // -Warray-bounds inside libstdc++ for that (a false positive, GCC bug 105329).
  std::string config =
      "[loop]\nclock = \"virtual\"\nduration = \"3s\"\n[device]\ndriver = \"loopback\"\ntorque_limit = 1.0\n"
      "[device.loopback]\nmotion = \"rotary\"\ndamping = 0.002\nmax_force = 1.2\ndelay = ";
  config += std::to_string(delay);
  config += "\nhand = \"" + hand + "\"\n" + scene;
  return config;
}

// The scripted hand's ideal 45-degree step moves the device 0.785 rad in
// one period (785 rad/s at 1 ms), faster than the default max_velocity lets
// a device move (docs/config.md, "Position plausibility"): runs with it
// allow that speed.
std::string allowing_ideal_steps(std::string config) {
  const std::string device = "[device]\n";
  const auto at = config.find(device);
  if (at != std::string::npos) config.insert(at + device.size(), "max_velocity = 1000\n");
  return config;
}

std::size_t first_at_least(const std::vector<double>& v, double x) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] >= x) return i;
  return v.size();
}

/// The canopen run against a loopback run, each from its step, over n samples.
struct Comparison {
  double worst = INFINITY;        ///< largest |command difference| over the samples compared
  std::size_t stale = 0;          ///< samples whose position repeated the last while the reference moved
  std::size_t longest_stale = 0;  ///< the longest run of such samples in a row
  std::size_t set_aside = 0;
};

/// A TPDO that came late (this VM stalls the drive's process now and then)
/// leaves the scene the last position for a period: the sample shows it as a
/// repeated position while the reference moved. That sample and the three
/// after it (the velocity estimate's memory, the plant catching up) are set
/// aside; everything else is compared.
Comparison compare(const Recording& drive, const Recording& reference, std::size_t n) {
  const auto pa = drive.values("position_rad"), pb = reference.values("position_rad");
  const auto ca = drive.values("command_n_m"), cb = reference.values("command_n_m");
  const std::size_t ia = first_at_least(pa, 0.1), ib = first_at_least(pb, 0.1);
  Comparison c;
  if (ia + n > ca.size() || ib + n > cb.size()) return c;
  std::vector<bool> aside(n, false);
  std::size_t streak = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (pa[ia + i] != pa[ia + i - 1] || pb[ib + i] == pb[ib + i - 1]) {
      streak = 0;
      continue;
    }
    ++c.stale;
    c.longest_stale = std::max(c.longest_stale, ++streak);
    for (std::size_t j = i; j < std::min(n, i + 4); ++j) aside[j] = true;
  }
  c.worst = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (aside[i]) {
      ++c.set_aside;
      continue;
    }
    c.worst = std::max(c.worst, std::abs(ca[ia + i] - cb[ib + i]));
  }
  return c;
}

double peak(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

Recording loopback_reference(const std::string& hand, int delay) {
  TempDir dir;
  Daemon d(dir, allowing_ideal_steps(loopback_config(hand, delay)), {"--record", "run.csv"});
  EXPECT_EQ(d.wait(120s), 0) << d.log();
  return read_recording(dir.path / "run.csv");
}

json status_of(const Daemon& d) { return json::parse(d.ctl({"status", "--json"}).out); }

template <class Condition>
bool eventually(Condition&& condition, std::chrono::milliseconds limit = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return condition();
}

/// In the recording: every latched period has zero output, from the period
/// the fault was seen; torque flowed just before each latch; after each clear
/// the scene starts again at equilibrium (no step). Returns the latches seen.
/// A fault seen by read() (EMCY, statusword, missing TPDO or heartbeat) zeroes
/// that period's output. Only a dead link can be seen by write() instead (the
/// RPDO's send fails): that row's output was computed already, and went to no
/// one; zero from the next row. `write_seen_latch` is that latch's number.
int check_latches_zero_and_clears_without_a_step(const Recording& rec, int write_seen_latch = 0) {
  const auto flags = rec.values("flags"), applied = rec.values("applied_n_m");
  int latches = 0;
  for (std::size_t i = 1; i < flags.size(); ++i) {
    const bool latched = (static_cast<unsigned>(flags[i]) & 1u) != 0;
    const bool was = (static_cast<unsigned>(flags[i - 1]) & 1u) != 0;
    if (latched && !was) {
      ++latches;
      EXPECT_GT(std::abs(applied[i - 1]), 0.01) << "torque was flowing before latch " << latches;
    }
    if (latched && !(latches == write_seen_latch && !was)) {
      EXPECT_EQ(applied[i], 0.0) << "row " << i << ", latch " << latches;
    }
    if (!latched && was) {
      EXPECT_LT(std::abs(applied[i]), 0.01) << "torque step after the clear at row " << i;
    }
  }
  return latches;
}

Recording canopen_step_run() {
  TempDir dir;
  SimulatedDrive drive(dir, releasing_hand);
  // tpdo_timeout: this VM stalls the drive's process for tens of ms now and then.
  Daemon d(dir, allowing_ideal_steps(canopen_config(drive.interface(), "duration = \"3s\"\n", 1000)),
           {"--record", "run.csv"});
  EXPECT_EQ(d.wait(60s), 0) << d.log();
  Recording run = read_recording(dir.path / "run.csv");
  EXPECT_NE(run.header.at("device").find("canopen"), std::string::npos);
  EXPECT_NE(run.header.at("device").find("d = 1"), std::string::npos) << "the device delay the gate used";
  return run;
}

TEST(Canopen, StepMatchesTheLoopbackRunWithOnePeriodOfDeviceDelay) {
  const Recording one = loopback_reference(releasing_hand, 1);
  const double peak_torque = peak(one.values("command_n_m"));
  ASSERT_GT(peak_torque, 0.5);
  // A drive process the VM leaves unscheduled for long (quiet runs show up
  // to 80 late TPDOs in 3000 periods, a few in a row; one at load 10 under
  // ctest -j2 showed 260) answers a burst of SYNCs late, the scene sees stale
  // positions for that long and the runs part: such a run is repeated, at
  // most twice, and said so; the last one is judged whatever it shows.
  constexpr std::size_t disturbed_run = 120, disturbed_streak = 10;  // 120 late: about 480 set aside
  Recording drive_run;
  Comparison with_one;
  for (int attempt = 1; attempt <= 3; ++attempt) {
    drive_run = canopen_step_run();
    with_one = compare(drive_run, one, 2000);
    if (with_one.stale <= disturbed_run && with_one.longest_stale <= disturbed_streak) break;
    std::cout << "run " << attempt << " disturbed by the VM: " << with_one.stale << " late TPDOs, "
              << with_one.longest_stale << " in a row"
              << (attempt < 3 ? ", repeated\n" : ", judged anyway\n");
  }
  EXPECT_LT(with_one.worst, 0.01 * peak_torque)
      << "worst difference " << with_one.worst << " N m, peak " << peak_torque << " N m";
  EXPECT_LT(with_one.set_aside, 500U) << "too many late TPDOs to compare: " << with_one.stale;
  // The comparison tells the delays apart: without the device's period the run is off by more.
  const Recording none = loopback_reference(releasing_hand, 0);
  const Comparison with_none = compare(drive_run, none, 2000);
  EXPECT_GT(with_none.worst, 0.01 * peak_torque) << "delay 0: " << with_none.worst << " N m";
  std::cout << "worst torque difference over 2 s from the step, peak " << peak_torque
            << " N m: " << with_one.worst << " N m against the loopback with one period of delay ("
            << with_one.stale << " late TPDOs, at most " << with_one.longest_stale << " in a row, "
            << with_one.set_aside << " samples set aside), " << with_none.worst << " N m with none\n";
}

/// The torque the drive applies now (its status line's force=, N m).
double drive_force(SimulatedDrive& drive) {
  const std::string status = drive.command("status");
  const auto at = status.find(" force=");
  return at == std::string::npos ? 0.0 : std::strtod(status.c_str() + at + 7, nullptr);
}

/// After a clear the scene restarts at equilibrium and the 1 Hz hand builds
/// the torque up from zero: a fault injected at a fixed time could land
/// near a zero crossing, where "torque flowed before the latch" (more than
/// 0.01 N m) is not so. Wait (bounded) until it clearly flows.
bool torque_flows(SimulatedDrive& drive) {
  return eventually([&] { return std::abs(drive_force(drive)) > 0.05; });
}

TEST(Canopen, FaultsZeroTheOutputWithTheDrivesReasonAndClearWithoutATorqueStep) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_hand);
  // tpdo_timeout 1000 periods: with 20, and even 200, a drive process the
  // VM left unscheduled (load 10, ctest -j2) latched a missing TPDO before the
  // EMCY came.
  Daemon d(dir, canopen_config(drive.interface(), "", 1000), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(
      eventually([&] { return status_of(d)["cycle"].get<double>() > 1500; }));  // torque flows since 0.5 s
  ASSERT_TRUE(status_of(d)["fault"].is_null()) << status_of(d)["device"].dump();

  // An EMCY from the drive.
  EXPECT_EQ(drive.command("fault 0x2310"), "ok EMCY 0x2310: continuous over current (motor side)");
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  json s = status_of(d);
  EXPECT_EQ(s["device"]["state"], "fault");
  EXPECT_EQ(
      s["device"]["fault_reason"],
      "node 1 EMCY 0x2310: continuous over current (motor side); error register 0x03 (generic, current); "
      "manufacturer bytes 00 00 00 00 00");
  EXPECT_NE(drive.command("status").find(" force=0 "), std::string::npos);
  auto r = d.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["device"], s["device"]["fault_reason"]);
  EXPECT_TRUE(status_of(d)["fault"].is_null());
  EXPECT_NE(drive.command("status").find("state=\"Operation Enabled\""), std::string::npos);

  // TPDOs stop coming.
  ASSERT_TRUE(torque_flows(drive)) << drive.command("status");
  EXPECT_EQ(drive.command("drop-tpdo all"), "ok dropping every TPDO");
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  EXPECT_EQ(status_of(d)["device"]["fault_reason"], "no TPDO1 (0x181) from node 1 for 1000 periods");
  drive.command("clear");
  r = d.ctl({"fault", "clear"});
  ASSERT_EQ(r.exit_code, 0) << r.err;

  // The drive dies.
  ASSERT_TRUE(torque_flows(drive)) << drive.command("status");
  drive.kill_now();
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  EXPECT_EQ(status_of(d)["device"]["fault_reason"],
            "the bus connection closed (the simulated drive's bus program ended?)");
  r = d.ctl({"fault", "clear"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("the drive stays in fault: the bus connection closed"), std::string::npos) << r.err;
  EXPECT_EQ(d.stop(), 0) << d.log();

  // The third, the killed drive, may be seen by read() or by write().
  EXPECT_EQ(check_latches_zero_and_clears_without_a_step(read_recording(dir.path / "run.csv"), 3), 3);
}

TEST(Canopen, ASilentDriveLatchesOnItsLostHeartbeatAndFaultClearReenablesIt) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_hand);
  // TPDOs may be missing for 3 s: the drive's heartbeat (timeout 1 s) is what is missed first.
  Daemon d(dir, canopen_config(drive.interface(), "", 3000), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  // Enabled through the CiA 402 state machine, torque reaching the drive.
  ASSERT_TRUE(eventually(
      [&] { return drive.command("status").find("state=\"Operation Enabled\"") != std::string::npos; }));
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 1500; }));
  EXPECT_EQ(status_of(d)["device"]["state"], "enabled");
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque reaches the drive";

  EXPECT_EQ(drive.command("mute"), "ok muted");
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  json s = status_of(d);
  EXPECT_EQ(s["device"]["state"], "fault");
  const std::string reason = s["device"]["fault_reason"];
  EXPECT_EQ(reason.rfind("no heartbeat from node 1 for ", 0), 0U) << reason;
  std::cout << "silent drive: hapticd latched \"" << reason << "\" (heartbeat_timeout 1 s)\n";
  // A second `fault clear` while the drive is still silent cannot enable it.
  auto r = d.ctl({"fault", "clear"});
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_FALSE(status_of(d)["fault"].is_null());

  // It answers again: its own consumer has meanwhile lost hapticd's heartbeat
  // (it was deaf too), so it comes back in Fault; the clear's fault-reset edge
  // and the enable sequence bring it to Operation Enabled.
  EXPECT_EQ(drive.command("unmute"), "ok answering");
  std::this_thread::sleep_for(300ms);
  r = d.ctl({"fault", "clear"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(status_of(d)["fault"].is_null());
  EXPECT_EQ(status_of(d)["device"]["state"], "enabled");
  EXPECT_NE(drive.command("status").find("state=\"Operation Enabled\""), std::string::npos);
  const double cycle = status_of(d)["cycle"].get<double>();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > cycle + 500; }));
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque flows again";
  EXPECT_EQ(d.stop(), 0) << d.log();
  EXPECT_EQ(check_latches_zero_and_clears_without_a_step(read_recording(dir.path / "run.csv")), 1);
}

// A TPDO that misses its period leaves the scene the last position (the
// driver's documented rule, below tpdo_timeout_periods): rendered, no fault,
// and flagged stale_position (64) in the recording, one row per missing TPDO,
// so a run can tell it from a device at rest (issue 21: a burst of them was
// the passivity run's "release transient").
TEST(Canopen, MissingTpdosBelowTheTimeoutAreRenderedAsStalePositionsFlaggedInTheRecording) {
  TempDir dir;
  // SCHED_FIFO for the drive: late TPDOs of its own would blur the count.
  SimulatedDrive drive(dir, turning_hand, rigid_wheel_plant, {}, 70);
  Daemon d(dir, canopen_config(drive.interface(), "", 1000), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 700; }));  // torque flows
  EXPECT_EQ(drive.command("drop-tpdo 6"), "ok dropping 6 TPDOs");
  const double cycle = status_of(d)["cycle"].get<double>();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > cycle + 300; }));
  EXPECT_TRUE(status_of(d)["fault"].is_null()) << "six missing of 1000 allowed";
  EXPECT_EQ(d.stop(), 0) << d.log();

  const Recording rec = read_recording(dir.path / "run.csv");
  const auto flags = rec.values("flags"), position = rec.values("position_rad"),
             applied = rec.values("applied_n_m");
  const auto stale = [&](std::size_t i) { return (static_cast<unsigned>(flags[i]) & 64u) != 0; };
  // The longest run of stale rows: the six dropped (a late TPDO of the VM's may join them).
  std::size_t best_start = 0, best = 0;
  for (std::size_t i = 0; i < flags.size();) {
    if (!stale(i)) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < flags.size() && stale(j)) ++j;
    if (j - i > best) best_start = i, best = j - i;
    i = j;
  }
  ASSERT_GE(best, 6U) << "the six dropped TPDOs, one stale row each";
  ASSERT_GT(best_start, 0U);
  ASSERT_LT(best_start + best, flags.size());
  for (std::size_t i = best_start; i < best_start + best; ++i) {
    EXPECT_EQ(position[i], position[best_start - 1]) << "row " << i << ": the last position stands";
    EXPECT_EQ(static_cast<unsigned>(flags[i]) & 1u, 0U) << "row " << i << ": no fault";
    EXPECT_NE(applied[i], 0.0) << "row " << i << ": rendered";
  }
  EXPECT_FALSE(stale(best_start + best));
}

TEST(Canopen, HapticctlDeviceSdoCommissionsTheRunningDrive) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_hand);
  Daemon d(dir, canopen_config(drive.interface(), "", 1000));
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(
      eventually([&] { return status_of(d)["cycle"].get<double>() > 1500; }));  // torque flows since 0.5 s
  EXPECT_EQ(status_of(d)["device"]["state"], "enabled");

  auto r = d.ctl({"device", "sdo", "read", "0x6041", "0", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto statusword = json::parse(r.out)["value"].get<int>();
  EXPECT_EQ(statusword & 0x6F, 0x27) << "Operation Enabled by the mask/value table: " << statusword;
  r = d.ctl({"device", "sdo", "read", "0x6041", "0"});
  EXPECT_EQ(r.out.rfind("0x6041:00 statusword = ", 0), 0U) << r.out;
  std::cout << "hapticctl device sdo read 0x6041 0: " << r.out;

  // The mapping is the cyclic exchange's: refused while enabled, in words.
  r = d.ctl({"device", "sdo", "write", "0x1A00", "0", "0"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(
      r.err.find("0x1A00:00 TPDO1 mapping parameter: what the bytes of the position hapticd reads mean; "
                 "refused while the drive is enabled"),
      std::string::npos)
      << r.err;
  // An object outside the guarded list goes to the drive; the drive's own abort, decoded.
  EXPECT_EQ(drive.command("sdo-abort 0x6065:0 0x06090031").rfind("ok", 0), 0U);
  r = d.ctl({"device", "sdo", "write", "0x6065", "0", "4000", "--type", "u32"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("aborted 0x06090031 (value too high)"), std::string::npos) << r.err;

  // Commissioning went through the loop's exchange without disturbing it.
  EXPECT_TRUE(status_of(d)["fault"].is_null()) << status_of(d)["device"].dump();
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque still flows";
  EXPECT_EQ(d.stop(), 0) << d.log();
}

// Issue 17: `device sdo write 0x6076 0 10000` was accepted while enabled; the
// drive then applied 10x the torque hapticd reported, past torque_limit.
TEST(Canopen, WritesThatScaleOrBoundTheTorqueAreRefusedWhileEnabledWithTheirRole) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_hand);
  Daemon d(dir, canopen_config(drive.interface(), "", 1000));
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 1500; }));  // torque flows
  const json described = json::parse(d.ctl({"device", "describe", "--json"}).out);
  EXPECT_EQ(described["counters"]["rated_torque_mnm"], 1000) << described.dump();  // the scale in use

  auto r = d.ctl({"device", "sdo", "write", "0x6076", "0", "10000"});
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.err.find("0x6076:00 motor rated torque: the scale of every torque hapticd sends; refused while "
                       "the drive is enabled, disable it first"),
            std::string::npos)
      << r.err;
  r = d.ctl({"device", "sdo", "write", "0x6072", "0", "1500"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("0x6072:00 max torque: the drive's bound on every torque hapticd sends; refused"),
            std::string::npos)
      << r.err;
  r = d.ctl({"device", "sdo", "write", "0x1029", "1", "1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("0x1029:01 error behaviour: what the drive does on a communication error"),
            std::string::npos)
      << r.err;
  for (const char* index : {"0x607E", "0x608F", "0x6091", "0x6092", "0x60B2", "0x6060", "0x1017"}) {
    r = d.ctl({"device", "sdo", "write", index, "0", "1", "--type", "u8"});
    EXPECT_EQ(r.exit_code, 1) << index;
    EXPECT_NE(r.err.find("; refused while the drive is enabled"), std::string::npos)
        << index << ": " << r.err;
  }
  // The JSON-RPC error itself: -32000 (refused) with the role in its message.
  {
    RawConnection c(d.socket());
    ASSERT_TRUE(c.send(
        R"({"jsonrpc":"2.0","id":1,"method":"device.sdo.write","params":{"index":"0x6076","sub":0,"value":10000}})"
        "\n"));
    const json reply = json::parse(c.read_line());
    EXPECT_EQ(reply["error"]["code"], -32000) << reply.dump();
    EXPECT_EQ(
        reply["error"]["message"].get<std::string>().rfind("0x6076:00 motor rated torque: the scale of every "
                                                           "torque hapticd sends; refused while the drive is "
                                                           "enabled",
                                                           0),
        0U)
        << reply.dump();
  }
  // Nothing reached the drive; torque still flows, no fault.
  r = d.ctl({"device", "sdo", "read", "0x6076", "0", "--json"});
  EXPECT_EQ(json::parse(r.out)["value"].get<int>(), 1000) << r.out;
  r = d.ctl({"device", "sdo", "read", "0x6072", "0", "--json"});
  EXPECT_NE(json::parse(r.out)["value"].get<int>(), 1500) << r.out;
  EXPECT_TRUE(status_of(d)["fault"].is_null()) << status_of(d)["device"].dump();
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque still flows";
  EXPECT_EQ(d.stop(), 0) << d.log();
}

TEST(Canopen, AKilledHapticdLetsTheDrivesHeartbeatConsumerDisableIt) {
  TempDir dir;
  SimulatedDrive drive(dir, step_hand);
  // 300 ms: with 100 ms the drive's consumer faulted it while hapticd was
  // alive, once, at load 11 (hapticd's loop went unscheduled that long).
  Daemon d(dir, allowing_ideal_steps(canopen_config(drive.interface(), "", 200, "300ms")));
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually(
      [&] { return drive.command("status").find("state=\"Operation Enabled\"") != std::string::npos; }));
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 700; }));
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque flows before";
  const auto killed = std::chrono::steady_clock::now();
  kill(d.pid(), SIGKILL);
  std::string status;
  ASSERT_TRUE(eventually([&] {
    status = drive.command("status");
    return status.find("fault=\"heartbeat of node 127 lost (consumer time 300 ms)\"") != std::string::npos;
  })) << status;
  const auto seen_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - killed);
  EXPECT_TRUE(
      eventually([&] { return drive.command("status").find("state=\"Fault\"") != std::string::npos; }));
  EXPECT_NE(drive.command("status").find(" force=0 "), std::string::npos);
  std::cout << "drive disabled itself " << seen_ms.count()
            << " ms after hapticd was killed (consumer time 300 ms)\n";
}

// Issue 17: a TPDO whose 0x6064 jumps by 2^31 counts once used to be taken
// as motion (no fault; torque at torque_limit until stop; no flag in the
// recording). The engine's position-step rule (max_velocity, for this wheel
// 50 + sqrt(2 x 1 N m x 2 pi / 0.01 kg m^2) = 85.4 rad/s) refuses it.
// A hand that turns the wheel between 0 and 0.6 rad, never below 0: the
// 32-bit count, once offset by 2^31, then never crosses its wrap (2^31 counts
// with a hand about 0 would wrap at each zero crossing, a jump of 2^32 counts
// each time: a real counter's wrap, refused too).
const char* const turning_above_zero =
    "mode=hold trajectory=sine position=0.3 amplitude=0.3 frequency=1 phase=-1.5707963267948966";

TEST(Canopen, A2To31CountJumpOf0x6064LatchesInItsPeriodWithTheFigures) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_above_zero);
  Daemon d(dir, canopen_config(drive.interface(), "", 1000), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 1500; }));  // torque flows
  ASSERT_TRUE(status_of(d)["fault"].is_null()) << status_of(d).dump();

  EXPECT_EQ(drive.command("position-jump 2147483648"),
            "ok 0x6064 jumps by 2147483648 increments from the next TPDO");
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  const json s = status_of(d);
  EXPECT_EQ(s["fault"], "encoder jump / velocity limit") << s.dump();
  EXPECT_EQ(s["device"]["state"], "enabled") << "the drive itself has no fault";
  const json& detail = s["fault_detail"];
  ASSERT_TRUE(detail.is_object()) << s.dump();
  // INTEGER32 wraps: the step is -2^31 or +2^31 counts, plus the hand's few counts of motion.
  EXPECT_NEAR(std::abs(detail["step_counts"].get<double>()), 2147483648.0, 20.0) << detail.dump();
  EXPECT_NEAR(std::abs(detail["step"].get<double>()), 823549.66, 1.0) << detail.dump();
  EXPECT_NEAR(detail["max_velocity"].get<double>(), 85.45, 0.01) << detail.dump();
  EXPECT_NEAR(detail["limit"].get<double>(),
              detail["max_velocity"].get<double>() * detail["interval_s"].get<double>() + 2 * M_PI / 16384,
              1e-9);
  EXPECT_NE(detail["text"].get<std::string>().find("counts) in "), std::string::npos) << detail.dump();
  std::this_thread::sleep_for(100ms);
  EXPECT_NE(drive.command("status").find(" force=0 "), std::string::npos)
      << "latched: no torque at the drive";

  const auto cleared = d.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(cleared.exit_code, 0) << cleared.err;
  EXPECT_EQ(json::parse(cleared.out)["cleared"], "encoder jump / velocity limit") << cleared.out;
  ASSERT_TRUE(eventually([&] { return status_of(d)["fault"].is_null(); }));
  const double cycle = status_of(d)["cycle"].get<double>();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > cycle + 500; }));
  EXPECT_TRUE(status_of(d)["fault"].is_null()) << "the offset position is the new normal";
  EXPECT_EQ(drive.command("status").find(" force=0 "), std::string::npos) << "torque flows again";
  EXPECT_EQ(d.stop(), 0) << d.log();

  const Recording rec = read_recording(dir.path / "run.csv");
  EXPECT_EQ(check_latches_zero_and_clears_without_a_step(rec), 1);
  const auto flags = rec.values("flags"), applied = rec.values("applied_n_m"),
             position = rec.values("position_rad");
  std::size_t jump = 0;
  while (jump < flags.size() && (static_cast<unsigned>(flags[jump]) & 32u) == 0) ++jump;
  ASSERT_LT(jump, flags.size()) << "no sample flagged position_jump";
  ASSERT_GT(jump, 0U);
  EXPECT_NE(static_cast<unsigned>(flags[jump]) & 1u, 0U) << "the fault flag on the jump's own sample";
  EXPECT_EQ(applied[jump], 0.0) << "zero output from the jump's period";
  EXPECT_GT(std::abs(position[jump] - position[jump - 1]), 800000.0);
  // While latched, nothing reaches the drive. After the clear the spring
  // wheel (tuned to 1 Hz) renders again under the 1 Hz hand and may reach
  // torque_limit by itself, however long the test took to clear it (CI's
  // ASan run saw it at row 3710): that span is the scene's, judged by
  // check_latches_zero_and_clears_without_a_step above.
  std::size_t resumed = jump;
  while (resumed < flags.size() && (static_cast<unsigned>(flags[resumed]) & 1u) != 0) ++resumed;
  ASSERT_LT(resumed, flags.size()) << "the latch was never cleared in the recording";
  for (std::size_t i = jump; i < resumed; ++i)
    ASSERT_EQ(applied[i], 0.0) << "row " << i << ": torque while latched after the jump";
}

// Issue 17, defect 10: the daemon checks the SDO methods' members like
// every method's: an unknown member or a wrong type is -32602 naming it,
// before the drive is asked anything, and an integer beyond int64 is not
// wrapped to a negative value.
TEST(Canopen, SdoMethodsRefuseUnknownMembersAndWrongTypes) {
  TempDir dir;
  SimulatedDrive drive(dir, turning_hand);
  Daemon d(dir, canopen_config(drive.interface(), "", 1000));
  ASSERT_TRUE(d.running()) << d.log();
  const auto ask = [&](const std::string& method, const std::string& params) {
    RawConnection c(d.socket());
    c.send(R"({"jsonrpc":"2.0","id":1,"method":")" + method + R"(","params":)" + params + "}\n");
    return json::parse(c.read_line(), nullptr, false);
  };
  const auto message = [](const json& reply) { return reply["error"].value("message", std::string()); };
  json r = ask("device.sdo.read", R"({"index":"0x6041","sub":0,"subindex":1})");
  EXPECT_EQ(r["error"]["code"], -32602) << r.dump();
  EXPECT_EQ(message(r), "device.sdo.read: unknown member 'subindex'; accepted: index, sub, type");
  r = ask("device.sdo.read", R"({"index":true})");
  EXPECT_EQ(r["error"]["code"], -32602) << r.dump();
  EXPECT_NE(message(r).find("member 'index' must be a number"), std::string::npos) << r.dump();
  r = ask("device.sdo.write", R"({"index":"0x6072","sub":0,"value":18446744073709551615})");
  EXPECT_EQ(r["error"]["code"], -32602) << r.dump();
  EXPECT_NE(message(r).find("member 'value'"), std::string::npos) << r.dump();
  r = ask("device.sdo.write", R"({"index":"0x6072","sub":0,"value":1500,"type":7})");
  EXPECT_EQ(message(r), "device.sdo.write: member 'type' must be a string, not an integer (7)") << r.dump();
  r = ask("device.sdo.read", R"({"index":"0x6041"})");
  EXPECT_TRUE(r.contains("result")) << r.dump();
  EXPECT_TRUE(status_of(d)["fault"].is_null()) << status_of(d).dump();
  EXPECT_EQ(d.stop(), 0) << d.log();
}

}  // namespace
}  // namespace hapticd::e2e::canopen_e2e_test
