// Issue 21 through a real driver's peer: the passivity controller (Hannaford
// & Ryu 2002) end to end with driver = "canopen" against the simulated CiA
// 402 drive (hapticd-devsim canopen) running the loopback's linear plant of
// tests/e2e/passivity_test.cpp: Hulin's device, m = 0.1 kg, T = 1 ms, the
// wall (B = 46 N s/m) one period late, the hand (200 N/m, 2 N s/m) pushing
// 4 mm past the face and letting go at 1 s.
//
// The period of delay is the drive's: it applies a torque at the next SYNC
// (d = 1 in the device, which the recording's header and the gate use), so
// the scene adds none. The loop is then the loopback run's (delay = 1 in the
// scene): the same fixed-gain limit 14342 N/m. (A scene delay on top gives
// d = 2: 3475 N/m, and B + passivity_max_damping = 76 N s/m is past the
// largest damper that loop holds, 53.6 N s/m: the gate refuses the controller.)
//
// The drive advances its plant one period per SYNC, so the run is the same in
// periods whatever the real clock does (a clean run repeats the samples of
// the loopback's with delay = 1 in the device for 35 periods, then parts by a
// count: the drive's 0.02 N torque steps), as long as each TPDO is back
// before hapticd's next period. A drive process the VM left unscheduled
// answers a burst of SYNCs late: hapticd renders the last position for those
// periods (flagged stale_position) and then the whole burst's motion as one
// period's, a kick through B and alpha. The drive's process runs SCHED_FIFO
// (as a drive answers in its own hardware), which makes that rare; the
// periods behind a stale position are set aside; three or more in a row
// (what the default tpdo_timeout_periods = 3 latches, allowed here so the VM
// does not end the run) in the judged span repeat the run, at most twice, and
// say so; the last one is judged whatever it shows.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include "tests/drivers/canopen/e2e/drive_process.hpp"
#include "tests/e2e/support.hpp"

namespace hapticd::e2e::passivity_canopen_test {
namespace passivity_canopen {
namespace {

constexpr double fixed_gain_limit = 14342.0;  // N/m: `hapticctl analyze wall` at beta = 0.46, d = 1
constexpr double stiffness = 1.95 * fixed_gain_limit;
constexpr double torque_limit = 40.0;  // N
constexpr double count = 3.14e-6;      // m: the loopback's linear encoder, the drive's 0x6064 increment
constexpr double static_penetration = 200.0 * 0.004 / (stiffness + 200.0);  // m: 28.4 um
constexpr unsigned flag_torque_limited = 2, flag_stale_position = 64;

const std::string hand = "mode=impedance stiffness=200 damping=2 position=0.005 release_at=1.0";
// The loopback's linear plant with the loopback test's 40 N actuator.
const std::string linear_plant = "motion=linear mass=0.1 damping=0 max_force=40";
// 0x6076 = 20 N: 40 N is 2000 per mille of it (under the drive's 0x6072 of
// 3000), 0.02 N per step of 0x6071.
const std::vector<std::string> drive_options = {"--rated-torque", "20"};
// SCHED_FIFO for the drive's process: a drive answers the SYNC in its own
// hardware; at load 7.7 on this VM, 0-1 stale positions in 5 runs of 6 (one
// burst of 9: a vCPU stall), against 25-107 with up to 11 in a row without.
constexpr int drive_fifo_priority = 70;

std::string wall_config(const std::string& interface, const std::string& passivity, bool force) {
  // overrun_limit = 0: this VM stalls the loop for tens of ms now and then.
  // tpdo_timeout_periods, heartbeat and SDO timeouts: as canopen_e2e_test.cpp.
  // Appended (GCC 12's -Warray-bounds on "text" + std::to_string(), bug 105329).
  std::string config =
      "[loop]\nperiod = \"1ms\"\noverrun_limit = 0\nduration = \"1.4s\"\n"
      "[device]\ndriver = \"canopen\"\ntorque_limit = 40\n"
      "[device.canopen]\ninterface = \"";
  config += interface;
  config +=
      "\"\nmotion = \"linear\"\ncounts_per_unit = 318471.33757961783\nmass = 0.1\ndamping = 0\n"
      "tpdo_timeout_periods = 1000\nheartbeat_timeout = \"1s\"\nsdo_timeout = \"1s\"\n"
      "[scene]\nname = \"wall\"\nstiffness = ";
  config += std::to_string(stiffness);
  config += "\ndamping = 46\ndelay = 0\nposition = 0.001\nside = \"upper\"\npassivity = \"";
  config += passivity;
  config += force ? "\"\nforce = true\n" : "\"\n";
  return config;
}

// Windows in cycles: the drive's plant steps once per SYNC, so the cycle is
// its clock (a few SYNCs of the setup ahead: the hand lets go at about cycle
// 996), whatever periods hapticd's real-clock loop missed.
struct Span {
  int from, to;  ///< cycles, from <= cycle < to
};
constexpr Span early{200, 300}, late{900, 990}, release{990, 1100}, after{1200, 1300};
constexpr Span push{100, 990};

struct Window {
  double lo = 1e9, hi = -1e9;  ///< penetration range, m
  double peak_force = 0.0;     ///< largest |applied|, N
  double min_energy = 1e9;     ///< J, when the recording has passivity_energy
  double max_damping = 0.0;    ///< N s/m, the controller's alpha
  int rows = 0;
  int set_aside = 0;
  double span() const { return hi - lo; }
};

/// A stale position and the periods after it: the scene saw no motion, then
/// the motion of all those periods as one period's (a kick through B and the
/// controller's alpha), and the device rings for a few periods after.
constexpr std::size_t aftermath_periods = 10;

std::vector<bool> behind_stale_positions(const Recording& rec) {
  const auto flags = rec.values("flags");
  std::vector<bool> aside(flags.size(), false);
  for (std::size_t i = 0; i < flags.size(); ++i) {
    if ((static_cast<unsigned>(flags[i]) & flag_stale_position) == 0) continue;
    for (std::size_t j = i; j < std::min(flags.size(), i + 1 + aftermath_periods); ++j) aside[j] = true;
  }
  return aside;
}

/// Rows with s.from <= cycle < s.to, without those `aside` marks (if given).
Window window(const Recording& rec, Span s, const std::vector<bool>* aside = nullptr) {
  const auto cycle = rec.values("cycle");
  const auto p = rec.values("penetration_m");
  const auto f = rec.values("applied_n");
  const bool observed = rec.has_column("passivity_energy_j");
  const auto e = observed ? rec.values("passivity_energy_j") : std::vector<double>(cycle.size(), 0.0);
  const auto alpha =
      observed ? rec.values("passivity_damping_n_s_per_m") : std::vector<double>(cycle.size(), 0.0);
  Window w;
  for (std::size_t i = 0; i < cycle.size(); ++i) {
    if (cycle[i] < s.from || cycle[i] >= s.to) continue;
    if (aside != nullptr && (*aside)[i]) {
      ++w.set_aside;
      continue;
    }
    w.lo = std::min(w.lo, p[i]);
    w.hi = std::max(w.hi, p[i]);
    w.peak_force = std::max(w.peak_force, std::abs(f[i]));
    w.min_energy = std::min(w.min_energy, e[i]);
    w.max_damping = std::max(w.max_damping, alpha[i]);
    ++w.rows;
  }
  return w;
}

struct Staleness {
  int periods = 0;  ///< stale_position rows in the span
  int longest = 0;  ///< the longest run of them in a row
};

Staleness staleness(const Recording& rec, Span s) {
  const auto cycle = rec.values("cycle");
  const auto flags = rec.values("flags");
  Staleness out;
  int streak = 0;
  for (std::size_t i = 0; i < cycle.size(); ++i) {
    if (cycle[i] < s.from || cycle[i] >= s.to) continue;
    if ((static_cast<unsigned>(flags[i]) & flag_stale_position) == 0) {
      streak = 0;
      continue;
    }
    ++out.periods;
    out.longest = std::max(out.longest, ++streak);
  }
  return out;
}

bool has_comment(const Recording& rec, const std::string& part) {
  return std::any_of(rec.comments.begin(), rec.comments.end(),
                     [&](const std::string& c) { return c.find(part) != std::string::npos; });
}

std::string um(double m) { return std::to_string(static_cast<int>(std::lround(m * 1e6))); }

/// One run through the drive, repeated (at most twice) while a burst of three
/// or more stale periods disturbs the judged span.
Recording run_through_the_drive(const std::string& passivity, bool force, Span judged) {
  constexpr int disturbing_streak = 3;  // what the default tpdo_timeout_periods latches
  Recording rec;
  for (int attempt = 1; attempt <= 3; ++attempt) {
    TempDir dir;
    SimulatedDrive drive(dir, hand, linear_plant, drive_options, drive_fifo_priority);
    Daemon daemon(dir, wall_config(drive.interface(), passivity, force), {"--record", "run.csv"});
    EXPECT_EQ(daemon.wait(std::chrono::seconds(60)), 0) << daemon.log() << drive.log();
    rec = read_recording(dir.path / "run.csv");
    const Staleness s = staleness(rec, judged);
    const bool complete = window(rec, after).rows > 0;
    if (s.longest < disturbing_streak && complete) break;
    std::cout << passivity << " run " << attempt << " disturbed by the VM: " << s.periods
              << " stale positions, " << s.longest << " in a row"
              << (complete ? "" : ", the loop missed periods past the last window")
              << (attempt < 3 ? ", repeated\n" : ", judged anyway\n");
  }
  return rec;
}

TEST(PassivityCanopen, TwiceTheLimitThroughTheDriveIsAcceptedWithTheControllerAndStaysBounded) {
  const Recording rec = run_through_the_drive("controller", false, {0, after.to});
  EXPECT_NE(rec.header.at("device").find("canopen"), std::string::npos);
  EXPECT_NE(rec.header.at("device").find("d = 1"), std::string::npos) << "the drive's period, in the gate";
  EXPECT_TRUE(has_comment(rec,
                          "1.95 x the fixed-gain limit 1.434e+04 N/m; accepted with the passivity "
                          "controller (Hannaford & Ryu 2002), up to 2 x"));
  // The observer pairs each force with the SYNC it acted at (the daemon set it from the drive).
  EXPECT_TRUE(has_comment(rec, "# parameter passivity_device_delay: 1 periods"));
  EXPECT_TRUE(has_comment(rec, "# parameter passivity_velocity_deadband: 0.00471 m/s"));

  // Judged without the periods behind a stale position (a VM artefact, set
  // aside as canopen_e2e_test.cpp's comparison does); the whole run is bounded too.
  const std::vector<bool> aside = behind_stale_positions(rec);
  const Window e = window(rec, early, &aside), l = window(rec, late, &aside);
  const Window held = window(rec, push, &aside), r = window(rec, release, &aside);
  const Window a = window(rec, after, &aside), all = window(rec, {0, 1'000'000});
  ASSERT_GT(e.rows, 20);
  ASSERT_GT(l.rows, 20);
  // Held in the wall, a bounce of a few static penetrations that does not
  // grow (the loopback with the drive's delay: -102..80 um early, -105..83 um late).
  EXPECT_LT(l.hi, 6.0 * static_penetration);
  EXPECT_LT(l.span(), 2.0 * e.span() + 2 * count);
  EXPECT_LT(l.span(), 0.5e-3);
  // Far below the 40 N limit (the hand pushes with 0.8 N; the loopback 4.4 N).
  EXPECT_LT(held.peak_force, 12.0);
  // With the kicks behind stale positions and the first impact (16.3 N, as
  // the loopback's, sample for sample): still short of the limit, which
  // clips every bounce without the controller.
  EXPECT_LT(all.peak_force, 0.75 * torque_limit);
  // passivity_energy bounded: the first impact's -4.0 mJ (as the loopback's)
  // is its lowest; late in the push it is back within that.
  for (const double x : rec.values("passivity_energy_j")) ASSERT_TRUE(std::isfinite(x));
  EXPECT_GT(all.min_energy, -8e-3);
  EXPECT_GT(l.min_energy, -4e-3);
  // The release is no transient: the wall lets the device go with what it
  // held (1/2 K p^2 <= 0.1 mJ at 83 um), not with a kick (-38 N seen once by
  // hand: behind a burst of stale positions, 9 x the push's peak).
  EXPECT_LT(r.peak_force, 1.5 * held.peak_force);
  // Let go, the controller leaves the free device alone (no damper
  // dithering it between two counts) and nothing holds it in the wall.
  // Unlike the loopback's, the release may fall in a phase of the bounce
  // where the device coasts back to the face below the deadband (4.71 mm/s):
  // a touch of a few um (K p + B v at 14 um and 4.71 mm/s: 0.6 N) is physics.
  ASSERT_GT(a.rows, 20);
  EXPECT_EQ(a.max_damping, 0.0);
  EXPECT_LT(a.hi, 0.5 * static_penetration);
  EXPECT_LT(a.peak_force, 1.0);
  const Staleness s = staleness(rec, {0, 1'000'000});
  std::cout << "controller through the drive: early " << um(e.lo) << ".." << um(e.hi) << " um, late "
            << um(l.lo) << ".." << um(l.hi) << " um (static " << um(static_penetration) << " um); peak "
            << l.peak_force << " N late, " << held.peak_force << " N in the push, " << r.peak_force
            << " N at the release, " << all.peak_force
            << " N in the whole run; passivity_energy >= " << all.min_energy * 1e3 << " mJ ("
            << l.min_energy * 1e3 << " mJ late); " << s.periods << " stale positions, at most " << s.longest
            << " in a row (" << held.set_aside << " periods of the push set aside)\n";
}

/// The largest |applied| of each contact (a run of periods with force) in turn.
std::vector<double> contact_peaks(const Recording& rec) {
  std::vector<double> peaks;
  bool in_contact = false;
  for (const double f : rec.values("applied_n")) {
    if (f == 0.0) {
      in_contact = false;
      continue;
    }
    if (!in_contact) peaks.push_back(0.0);
    in_contact = true;
    peaks.back() = std::max(peaks.back(), std::abs(f));
  }
  return peaks;
}

TEST(PassivityCanopen, WithoutTheControllerTheSameWallThrowsTheDeviceOffAtTheTorqueLimit) {
  // Judged from the first contacts on: a later burst only adds to the violence.
  const Recording rec = run_through_the_drive("off", true, {0, 250});
  EXPECT_FALSE(rec.has_column("passivity_energy_j"));
  EXPECT_TRUE(has_comment(rec, "unstable")) << "the gate's verdict, forced";
  const Window e = window(rec, early), l = window(rec, late);
  // Growing: each bounce hits harder (the loopback's: 13.0, 19.1, 25.3,
  // 29.8, 33.0 N ...) until the torque limit clips them.
  const std::vector<double> peaks = contact_peaks(rec);
  ASSERT_GE(peaks.size(), 4U);
  EXPECT_LT(peaks[0], 0.5 * torque_limit);
  for (std::size_t i = 1; i < 4; ++i) EXPECT_GT(peaks[i], peaks[i - 1]) << "contact " << i;
  EXPECT_GE(l.peak_force, torque_limit - 1e-9);
  EXPECT_GT(l.span(), 1e-3);  // millimetres, against tenths of a millimetre with the controller
  const auto flags = rec.values("flags");
  EXPECT_TRUE(std::any_of(flags.begin(), flags.end(),
                          [](double f) { return (static_cast<unsigned>(f) & flag_torque_limited) != 0; }));
  std::cout << "off (forced) through the drive: contacts at " << peaks[0] << ", " << peaks[1] << ", "
            << peaks[2] << ", " << peaks[3] << " N ...; early " << um(e.lo) << ".." << um(e.hi) << " um at "
            << e.peak_force << " N, late " << um(l.lo) << ".." << um(l.hi) << " um at " << l.peak_force
            << " N\n";
}

}  // namespace
}  // namespace passivity_canopen
}  // namespace hapticd::e2e::passivity_canopen_test
