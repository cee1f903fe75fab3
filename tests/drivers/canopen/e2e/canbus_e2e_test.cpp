// Several CiA 402 drives on one bus, end to end (issue 22): hapticd-devsim
// canbus as its own process, two hapticd-devsim canopen drives joining it
// (--connect, nodes 1 and 2, each on its own plant and hand), and the real
// hapticd with node_ids = "1,2" joining it too:
//   - the two-axis scene of the loopback stage (plane-wall n = (1, 1)/sqrt 2,
//     the hand moving x 5 mm either side of the plane) renders the same
//     task force on both axes as the loopback stage with one period of
//     device delay, within 1 % of the peak;
//   - an EMCY from node 2 zeroes both axes in the period it is seen, with
//     the axis and the node in `hapticctl status`, and `fault clear` brings
//     both back;
//   - a period the bus cannot carry for two nodes is refused at start with
//     the bits per period and the bit rate;
//   - homing = "cia402" with each node's own method and offset
//     (axis_homing_method, axis_home_offset): both drives home before the
//     loop, each on its own switch, and the loop starts from the homes;
//     `hapticctl device sdo read ... --node N` reads the node named, and a
//     write of what scales its torque is refused while enabled.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/drivers/canopen/e2e/drive_process.hpp"
#include "tests/e2e/support.hpp"

namespace hapticd::e2e::canbus_e2e_test {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

// A hand on a spring (impedance) moves x through the plane and back, 5 mm
// either side, at 1 Hz; another holds y at 0 on the same spring. The wall's
// force along n moves both plants, so the device's delay shows in it.
const std::string x_hand =
    "mode=impedance trajectory=sine amplitude=0.005 frequency=1 phase=1.5707963 stiffness=2000 damping=10";
const std::string y_hand = "mode=impedance stiffness=2000 damping=10";
const std::string scene =
    "[scene]\nname = \"plane-wall\"\nnormal = \"1,1\"\nstiffness = 2000\ndamping = 46\ndelay = 0\n";

/// The drive's plant: the loopback stage's axis (linear, rigid, undamped), 0.1 um counts.
std::string axis_plant(double mass) {
  return "motion=linear mass=" + std::to_string(mass) + " damping=0 counts=10000000";
}

std::string loopback_stage_config(int delay) {
  std::string config =
      "[loop]\nclock = \"virtual\"\nduration = \"3s\"\n[device]\ndriver = \"loopback\"\ntorque_limit = 10.0\n"
      "[device.loopback]\naxes = 2\naxis_mass = \"0.1,0.3\"\naxis_damping = \"0,0\"\ncounts = 10000000\n"
      "delay = ";
  config += std::to_string(delay);
  config += "\nhands = \"";
  config += x_hand + "; " + y_hand + "\"\n" + scene;
  return config;
}

/// heartbeat_timeout and sdo_timeout 1 s, tpdo_timeout 1000 periods: this VM
/// leaves a drive's process unscheduled for tens of ms now and then.
std::string canbus_config(const std::string& interface, const std::string& loop,
                          const std::string& scene_text = scene) {
  return "[loop]\nperiod = \"1ms\"\noverrun_limit = 0\n" + loop +
         "[device]\ndriver = \"canopen\"\ntorque_limit = 10.0\n"
         "[device.canopen]\ninterface = \"" +
         interface +
         "\"\nnode_ids = \"1,2\"\nmotion = \"linear\"\ncounts_per_unit = 10000000\naxis_mass = \"0.1,0.3\"\n"
         "axis_damping = \"0,0\"\nmass = 0.1\nheartbeat_timeout = \"1s\"\nsdo_timeout = \"1s\"\n"
         "tpdo_timeout_periods = 1000\n" +
         scene_text;
}

/// hapticd, the bus and the two drives as the test runs them.
struct Stage {
  explicit Stage(const TempDir& dir, const std::string& hand1 = x_hand, const std::string& hand2 = y_hand)
      : bus(dir, 70),
        node1(SimulatedDrive::member(dir, bus.interface(), 1, hand1, axis_plant(0.1), {"--rated-torque", "4"},
                                     70)),
        node2(SimulatedDrive::member(dir, bus.interface(), 2, hand2, axis_plant(0.3), {"--rated-torque", "4"},
                                     70)) {}
  SimulatedCanBus bus;
  std::unique_ptr<SimulatedDrive> node1, node2;
};

std::size_t first_below(const std::vector<double>& v, double x) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] < x) return i;
  return v.size();
}

struct Comparison {
  double worst = INFINITY;  ///< largest |force difference| on either axis over the rows compared
  double peak = 0.0;        ///< largest |force| of the reference on either axis
  std::size_t stale = 0;    ///< rows whose position came from a late TPDO
  std::size_t set_aside = 0;
  std::size_t pushing = 0;  ///< rows compared with a force
};

/// From the first row inside the wall in each run, n rows: both axes' task
/// force. A row behind a late TPDO (stale_position) and the 49 after it are
/// set aside and counted: the stale period's force moves the drive's plant
/// off the stage's, and the hand's and the wall's damping (2000 N/m with 10
/// N s/m, and 46 N s/m, on 0.1 kg) take that out within ~50 ms.
Comparison compare(const Recording& drive, const Recording& reference, std::size_t n) {
  const auto xa = drive.values("position_x_m"), xb = reference.values("position_x_m");
  const std::size_t ia = first_below(xa, 0.0), ib = first_below(xb, 0.0);
  Comparison c;
  if (ia + n > xa.size() || ib + n > xb.size()) return c;
  const auto flags = drive.values("flags");
  std::vector<bool> aside(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    if ((static_cast<unsigned>(flags[ia + i]) & 64U) == 0) continue;
    ++c.stale;
    for (std::size_t j = i; j < std::min(n, i + 50); ++j) aside[j] = true;
  }
  c.worst = 0.0;
  for (const char* column : {"force_x_n", "force_y_n"}) {
    const auto fa = drive.values(column), fb = reference.values(column);
    for (std::size_t i = 0; i < n; ++i) {
      c.peak = std::max(c.peak, std::abs(fb[ib + i]));
      if (aside[i]) continue;
      c.worst = std::max(c.worst, std::abs(fa[ia + i] - fb[ib + i]));
      if (std::abs(fb[ib + i]) > 0.0) ++c.pushing;
    }
  }
  for (std::size_t i = 0; i < n; ++i) c.set_aside += aside[i] ? 1 : 0;
  return c;
}

Recording loopback_stage(int delay) {
  TempDir dir;
  Daemon d(dir, loopback_stage_config(delay), {"--record", "run.csv"});
  EXPECT_EQ(d.wait(120s), 0) << d.log();
  return read_recording(dir.path / "run.csv");
}

Recording canbus_run() {
  TempDir dir;
  Stage stage(dir);
  Daemon d(dir, canbus_config(stage.bus.interface(), "duration = \"3s\"\n"), {"--record", "run.csv"});
  EXPECT_EQ(d.wait(60s), 0) << d.log() << stage.bus.log();
  Recording run = read_recording(dir.path / "run.csv");
  EXPECT_NE(run.header.at("device").find("CiA 402 drives on one bus, nodes 1, 2"), std::string::npos)
      << run.header.at("device");
  EXPECT_NE(run.header.at("device").find("d = 1"), std::string::npos) << "the device delay the gate used";
  return run;
}

TEST(CanopenBus, TwoDrivesOnTheBusRenderThePlaneWallAsTheLoopbackStage) {
  const Recording reference = loopback_stage(1);
  // A run the VM disturbed (late TPDOs) is repeated, at most twice, and
  // said so; the least disturbed of the runs is judged whatever it shows.
  constexpr std::size_t n = 2000;
  Comparison c;
  Recording run;
  for (int attempt = 1; attempt <= 3; ++attempt) {
    Recording next = canbus_run();
    const Comparison judged = compare(next, reference, n);
    if (attempt == 1 || judged.stale < c.stale) {
      c = judged;
      run = std::move(next);
    }
    if (c.stale == 0) break;
    std::cout << "run " << attempt << " disturbed by the VM: " << judged.stale << " late TPDOs"
              << (attempt < 3 ? ", repeated\n" : ", the least disturbed run judged\n");
  }
  ASSERT_GT(c.peak, 1.0) << "the wall pushes";
  EXPECT_GT(c.pushing, 1000U);
  EXPECT_LT(c.worst, 0.01 * c.peak) << "worst difference " << c.worst << " N, peak " << c.peak << " N";
  EXPECT_LT(c.set_aside, 1000U) << "too many late TPDOs to compare: " << c.stale;
  // The comparison tells the delays apart: without the device's period the stage is off by more.
  const Comparison without_delay = compare(run, loopback_stage(0), n);
  EXPECT_GT(without_delay.worst, 0.01 * c.peak) << "delay 0: " << without_delay.worst << " N";
  std::cout << "two drives on the bus against the loopback stage with one period of delay, " << n
            << " rows from the wall: worst task-force difference " << c.worst << " N on either axis, peak "
            << c.peak << " N (" << c.stale << " late TPDOs, " << c.set_aside << " rows set aside); "
            << without_delay.worst << " N against the stage without delay\n";
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

TEST(CanopenBus, AnEmcyOnOneNodeZeroesBothAxesThatPeriodNamingTheAxisAndNode) {
  TempDir dir;
  // Both hands push 3 mm into the wall and hold there: force flows on both axes.
  const std::string into_wall = "mode=hold trajectory=ramp from=0.002 to=-0.003 rate=0.01";
  Stage stage(dir, into_wall, into_wall);
  Daemon d(dir, canbus_config(stage.bus.interface(), ""), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<double>() > 1000; }));
  ASSERT_TRUE(status_of(d)["fault"].is_null()) << status_of(d).dump();
  EXPECT_EQ(stage.node1->command("status").find(" force=0 "), std::string::npos) << "torque flows on node 1";

  EXPECT_EQ(stage.node2->command("fault 0x2310"), "ok EMCY 0x2310: continuous over current (motor side)");
  ASSERT_TRUE(eventually([&] { return !status_of(d)["fault"].is_null(); }));
  const json s = status_of(d);
  EXPECT_EQ(s["device"]["state"], "fault");
  const std::string reason = s["device"]["fault_reason"];
  EXPECT_EQ(reason,
            "axis 2 (node 2): node 2 EMCY 0x2310: continuous over current (motor side); error register 0x03 "
            "(generic, current); manufacturer bytes 00 00 00 00 00; every axis held at zero");
  EXPECT_TRUE(eventually([&] {
    return stage.node1->command("status").find(" force=0 ") != std::string::npos;
  })) << "node 1, itself fine, gets torque 0: "
      << stage.node1->command("status");

  const auto r = d.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(status_of(d)["fault"].is_null());
  // Both back in Operation Enabled (the wall, cleared over the hands inside
  // it, waits for them to come out before it pushes again: docs/scenes.md).
  for (SimulatedDrive* node : {stage.node1.get(), stage.node2.get()})
    EXPECT_TRUE(eventually([&] {
      return node->command("status").find("state=\"Operation Enabled\"") != std::string::npos;
    })) << node->command("status");
  EXPECT_EQ(d.stop(), 0) << d.log();

  // The recording: torque on both axes just before, zero on both from the period the EMCY was seen.
  const Recording rec = read_recording(dir.path / "run.csv");
  const auto flags = rec.values("flags"), ox = rec.values("output_x_n"), oy = rec.values("output_y_n");
  int latches = 0;
  for (std::size_t i = 1; i < flags.size(); ++i) {
    const bool latched = (static_cast<unsigned>(flags[i]) & 1U) != 0;
    const bool was = (static_cast<unsigned>(flags[i - 1]) & 1U) != 0;
    if (latched && !was) {
      ++latches;
      EXPECT_GT(std::abs(ox[i - 1]), 1.0) << "x flowed before the latch";
      EXPECT_GT(std::abs(oy[i - 1]), 1.0) << "y flowed before the latch";
    }
    if (latched) {
      EXPECT_EQ(ox[i], 0.0) << "row " << i;
      EXPECT_EQ(oy[i], 0.0) << "row " << i;
    }
  }
  EXPECT_EQ(latches, 1);
}

TEST(CanopenBus, APeriodTheBusCannotCarryForTwoNodesIsRefusedWithTheFigures) {
  TempDir dir;
  // No bus needed: the budget is checked before the bus is touched.
  std::string config = canbus_config("unix:" + (dir.path / "no-bus.sock").string(), "");
  config.replace(config.find("period = \"1ms\""), 14, "period = \"500us\"");
  config.replace(config.find("[device.canopen]\n"), 17, "[device.canopen]\nbitrate = 1000000\n");
  Daemon d(dir, config);
  EXPECT_NE(d.wait(30s), 0);
  const std::string log = d.log();
  EXPECT_NE(log.find("hapticd.toml:8:11: 2 drives on one bus (nodes 1, 2, one SYNC): 5 frames (SYNC + RPDO1 "
                     "+ TPDO1 + RPDO1 + "
                     "TPDO1) = 475 bits worst case, + 135 bits for one frame of other traffic = 0.61 ms at 1 "
                     "Mbit/s: a 0.5 ms period needs 1.22 Mbit/s, above classic CAN's 1 Mbit/s"),
            std::string::npos)
      << log;
}

TEST(CanopenBus, EachDriveHomesOnItsOwnSwitchWithItsOwnMethodBeforeTheLoop) {
  TempDir dir;
  SimulatedCanBus bus(dir, 70);
  const std::vector<std::string> extra = {"--rated-torque", "4", "--limit-switches", "-0.5,0.5"};
  auto node1 = SimulatedDrive::member(dir, bus.interface(), 1, "mode=free", axis_plant(0.1), extra, 70);
  auto node2 = SimulatedDrive::member(dir, bus.interface(), 2, "mode=free", axis_plant(0.3), extra, 70);
  // Node 1 on its negative switch, node 2 on its positive one; a box far
  // larger than the travel, so nothing pushes after.
  const std::string keys =
      "homing = \"cia402\"\naxis_homing_method = \"17,18\"\naxis_home_offset = \"0.25,-0.1\"\n"
      "homing_speed_switch = 1.0\nhoming_speed_zero = 0.2\nhoming_acceleration = 10.0\nhoming_timeout = "
      "\"10s\"\n"
      "[scene]\nname = \"box\"\nlow = \"-2,-2\"\nhigh = \"2,2\"\nstiffness = 400\ndamping = 2\n";
  Daemon d(dir, canbus_config(bus.interface(), "", keys), {"--record", "run.csv"});
  const auto status = [&] {
    const auto r = d.ctl({"status", "--json"});
    return r.exit_code == 0 ? json::parse(r.out) : json::object();
  };
  ASSERT_TRUE(eventually(
      [&] {
        const json s = status();
        return s.contains("cycle") && s["cycle"].get<double>() > 300;
      },
      30s))
      << d.log() << bus.log();
  const json c = status()["calibration"];
  EXPECT_EQ(c["how"], "homed") << c.dump();
  EXPECT_EQ(c["homing_method"], 17) << "axis 1's";
  EXPECT_NE(d.ctl({"status"})
                .out.find("CiA 402 homing: node 1 method 17 (on the negative limit switch), node 2 "
                          "method 18 (on the positive limit switch)"),
            std::string::npos)
      << d.ctl({"status"}).out;
  // Commissioning reads name the node: both back in cyclic synchronous torque after homing.
  for (const char* node : {"1", "2"}) {
    const auto mode = d.ctl({"device", "sdo", "read", "0x6061", "0", "--node", node});
    ASSERT_EQ(mode.exit_code, 0) << mode.err;
    EXPECT_EQ(mode.out, "node " + std::string(node) +
                            ": 0x6061:00 modes of operation display = 10 (raw 0x0000000A, i8)\n");
  }
  const auto guarded = d.ctl({"device", "sdo", "write", "0x6076", "0", "2000", "--node", "2"});
  EXPECT_NE(guarded.exit_code, 0) << "a drive rescaled while enabled";
  EXPECT_NE(guarded.err.find("0x6076:00 motor rated torque"), std::string::npos) << guarded.err;
  const auto unnamed = d.ctl({"device", "sdo", "read", "0x6061", "0"});
  EXPECT_NE(unnamed.exit_code, 0);
  EXPECT_NE(unnamed.err.find("missing 'node': several drives share this bus; name one of node_ids 1, 2"),
            std::string::npos)
      << unnamed.err;
  EXPECT_EQ(d.stop(), 0) << d.log();
  // Each axis reads its own -home_offset at its own switch's edge and stopped just off it.
  const Recording rec = read_recording(dir.path / "run.csv");
  ASSERT_FALSE(rec.rows.empty());
  const double x = rec.values("position_x_m").front(), y = rec.values("position_y_m").front();
  EXPECT_GT(x, -0.25 - 1e-6);
  EXPECT_LT(x, -0.25 + 0.05) << "just above the negative switch";
  EXPECT_LT(y, 0.1 + 1e-6);
  EXPECT_GT(y, 0.1 - 0.05) << "just below the positive switch";
  std::cout
      << "two drives homed through hapticd, node 1 on its negative switch, node 2 on its positive one, in "
      << c.value("homing_periods", 0U) << " periods; first positions " << x << " m, " << y << " m\n";
}

}  // namespace
}  // namespace hapticd::e2e::canbus_e2e_test
