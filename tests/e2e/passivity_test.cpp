// Issue 21, end to end: the real hapticd on the loopback linear plant (Hulin's
// device: m = 0.1 kg, T = 1 ms, a wall one sample late with B = 46 N s/m, so
// the fixed-gain limit is 14342 N/m), a hand (200 N/m, 2 N s/m) that pushes
// 4 mm past the wall face and lets go at 1 s, on the virtual clock. With the
// passivity controller the contact stays bounded and the free device is left
// alone; without it the same wall throws the device off at the torque limit.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::passivity_test {
namespace {

constexpr double fixed_gain_limit = 14342.0;  // N/m: `hapticctl analyze wall` at beta = 0.46, d = 1
constexpr double torque_limit = 40.0;         // N
constexpr double count = 3.14e-6;             // m: the loopback's linear encoder

std::string contact_config(double stiffness, const std::string& passivity, bool force) {
  return "[loop]\nclock = \"virtual\"\nduration = \"1.5s\"\n"
         "[device]\ndriver = \"loopback\"\ntorque_limit = 40\n"
         "[device.loopback]\nmotion = \"linear\"\nmass = 0.1\nmax_force = 40\n"
         "hand = \"mode=impedance stiffness=200 damping=2 position=0.005 release_at=1.0\"\n"
         "[scene]\nname = \"wall\"\nstiffness = " +
         std::to_string(stiffness) +
         "\ndamping = 46\ndelay = 1\nposition = 0.001\nside = \"upper\"\npassivity = \"" + passivity +
         "\"\n" + (force ? "force = true\n" : "");
}

struct Window {
  double lo = 0.0, hi = 0.0;  ///< penetration range, m
  double peak_force = 0.0;    ///< largest |applied|, N
  double span() const { return hi - lo; }
};

/// Samples with from <= t < to.
Window window(const Recording& rec, double from, double to) {
  const auto t = rec.values("time_s");
  const auto p = rec.values("penetration_m");
  const auto f = rec.values("applied_n");
  Window w{1e9, -1e9, 0.0};
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < from || t[i] >= to) continue;
    w.lo = std::min(w.lo, p[i]);
    w.hi = std::max(w.hi, p[i]);
    w.peak_force = std::max(w.peak_force, std::abs(f[i]));
  }
  return w;
}

Recording run_contact(const TempDir& dir, const std::string& config) {
  Daemon daemon(dir, config, {"--record", "run.csv"});
  EXPECT_EQ(daemon.wait(std::chrono::seconds(120)), 0) << daemon.log();
  return read_recording(dir.path / "run.csv");
}

bool has_comment(const Recording& rec, const std::string& part) {
  return std::any_of(rec.comments.begin(), rec.comments.end(),
                     [&](const std::string& c) { return c.find(part) != std::string::npos; });
}

TEST(PassivityLoopback, TwiceTheLimitIsAcceptedWithTheControllerAndTheContactStaysBounded) {
  TempDir dir;
  const Recording rec = run_contact(dir, contact_config(1.95 * fixed_gain_limit, "controller", false));
  EXPECT_TRUE(has_comment(rec, "accepted with the passivity controller (Hannaford & Ryu 2002), up to 2 x"));
  // The deadband the daemon set from the device: 1.5 counts a period.
  EXPECT_TRUE(has_comment(rec, "# parameter passivity_velocity_deadband: 0.00471 m/s"));
  const auto energy = rec.values("passivity_energy_j");
  const auto alpha = rec.values("passivity_damping_n_s_per_m");
  ASSERT_FALSE(energy.empty());
  EXPECT_LE(*std::max_element(alpha.begin(), alpha.end()), 30.0);  // passivity_max_damping
  EXPECT_GT(*std::max_element(alpha.begin(), alpha.end()), 0.0);
  for (const double e : energy) ASSERT_TRUE(std::isfinite(e));
  EXPECT_GT(*std::min_element(energy.begin(), energy.end()), -5e-3);  // J: bounded

  const Window early = window(rec, 0.2, 0.3), late = window(rec, 0.9, 1.0);
  const double static_penetration = 200.0 * 0.004 / (1.95 * fixed_gain_limit + 200.0);  // 28.4 um
  // The push is held in the wall: what is left is a bounce of about the
  // static penetration (contact lost by a count or two), not growing.
  EXPECT_LT(late.hi, 3.0 * static_penetration);
  EXPECT_LE(late.span(), early.span() + 2 * count);
  EXPECT_LT(late.peak_force, 4.0);  // the hand pushes with 0.8 N
  // Let go: the device leaves and the controller leaves it alone (no damper
  // dithering it between two counts).
  EXPECT_EQ(window(rec, 1.2, 1.5).peak_force, 0.0);
  EXPECT_LT(window(rec, 1.2, 1.5).hi, 0.0);
}

TEST(PassivityLoopback, WithoutTheControllerTheSameWallThrowsTheDeviceOffAtTheTorqueLimit) {
  TempDir dir;
  const Recording rec = run_contact(dir, contact_config(1.95 * fixed_gain_limit, "off", true));
  EXPECT_FALSE(rec.has_column("passivity_energy_j"));
  const Window late = window(rec, 0.9, 1.0);
  EXPECT_GE(late.peak_force, torque_limit - 1e-9);
  EXPECT_GT(late.span(), 1e-3);  // millimetres, against tens of micrometres with the controller
}

TEST(PassivityLoopback, FiveTimesTheLimitIsRefusedButForcedItStaysBoundedWithTheController) {
  TempDir refused_dir;
  Daemon refused(refused_dir, contact_config(5.0 * fixed_gain_limit, "controller", false));
  EXPECT_EQ(refused.wait(std::chrono::seconds(30)), 2);
  EXPECT_NE(refused.log().find("with the passivity controller up to 2 x that = 2.868e+04 N/m"),
            std::string::npos)
      << refused.log();

  TempDir dir;
  const Recording rec = run_contact(dir, contact_config(5.0 * fixed_gain_limit, "controller", true));
  const Window early = window(rec, 0.2, 0.3), late = window(rec, 0.9, 1.0);
  EXPECT_LE(late.span(), 1.2 * early.span() + 2 * count);
  EXPECT_LT(late.span(), 0.5e-3);
  EXPECT_LT(late.peak_force, 10.0);

  TempDir off_dir;
  const Recording off = run_contact(off_dir, contact_config(5.0 * fixed_gain_limit, "off", true));
  EXPECT_GE(window(off, 0.9, 1.0).peak_force, torque_limit - 1e-9);
}

}  // namespace
}  // namespace hapticd::e2e::passivity_test
