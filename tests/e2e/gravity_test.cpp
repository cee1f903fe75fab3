// End-to-end, gravity compensation and the workspace wall (issue 22 item 7):
// the real hapticd on a two-axis Cartesian loopback stage (virtual clock)
// whose y axis is vertical (the plant carries axis_weight = -m g on y).
// With [gravity] the feedforward holds y still once the hand lets go, with
// the free scene; without it y falls. A [workspace] box holds the device
// inside while the scene is free and the hand pushes outward, F/K deep. A
// workspace wall too stiff for the device is refused at --check-config
// naming the limit, and the [gravity]/[workspace] errors name their key.
// The pantograph in a vertical plane (the loopback's link_masses): the
// links' feedforward holds the handle still once the hand lets go, and
// links too heavy for the torque limit are refused with the worst case.
// One vertical linear axis (the loopback's one-axis axis_weight): its
// weight is held after the scene and recorded (gravity_n); without it the
// axis falls.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "support.hpp"

namespace hapticd::e2e::gravity_test {
namespace {

using nlohmann::json;

constexpr double y_mass = 0.3;       // kg
constexpr double g = 9.80665;        // m/s^2
constexpr double resolution = 1e-9;  // m: counts = 1e9 per metre

/// x horizontal (0.1 kg), y vertical (0.3 kg) weighing -m g, both held by the hand at 0 to start.
std::string vertical_stage(const std::string& sections, const std::string& torque_limit = "10.0") {
  return "[loop]\nperiod = \"1ms\"\nclock = \"virtual\"\n"
         "[device]\ndriver = \"loopback\"\ntorque_limit = " +
         torque_limit +
         "\n"
         "[device.loopback]\naxes = 2\naxis_mass = \"0.1,0.3\"\naxis_damping = \"0,0\"\ncounts = 1e9\n"
         "axis_weight = \"0,-2.941995\"\n"  // -0.3 kg x 9.80665 m/s^2
         "hands = \"mode=hold; mode=hold\"\n"
         "[scene]\nname = \"free\"\n" +
         sections;
}

const std::string gravity_on_y = "[gravity]\naxis = \"y\"\nmass = 0.3\n";

/// Records while the hand lets go of `axis` (or pushes it), for `real` milliseconds.
Recording record_after(Daemon& daemon, const TempDir& dir, const std::vector<std::string>& hand,
                       int real_ms) {
  EXPECT_EQ(daemon.ctl({"record", "start", "--path", "run.csv"}).exit_code, 0) << daemon.log();
  std::vector<std::string> call{"device", "call", "hand.set"};
  call.insert(call.end(), hand.begin(), hand.end());
  const auto set = daemon.ctl(call);
  EXPECT_EQ(set.exit_code, 0) << set.err;
  std::this_thread::sleep_for(std::chrono::milliseconds(real_ms));
  EXPECT_EQ(daemon.ctl({"record", "stop"}).exit_code, 0) << daemon.log();
  EXPECT_EQ(daemon.stop(), 0) << daemon.log();
  return read_recording(dir.path / "run.csv");
}

TEST(Gravity, TheFeedforwardHoldsAVerticalAxisStillWhenTheHandLetsGo) {
  TempDir dir;
  Daemon daemon(dir, vertical_stage(gravity_on_y));
  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  const json st = json::parse(status.out);
  EXPECT_EQ(st["gravity"]["axis"], "y") << st.dump();
  EXPECT_EQ(st["gravity"]["mass"], 0.3);
  EXPECT_NEAR(st["gravity"]["feedforward"].get<double>(), y_mass * g, 1e-12);
  EXPECT_FALSE(st.contains("workspace"));

  const Recording rec = record_after(daemon, dir, {"axis=2", "mode=free"}, 400);
  const auto y = rec.values("position_y_m"), gy = rec.values("gravity_y_n"), gx = rec.values("gravity_x_n");
  const auto oy = rec.values("output_y_n"), flags = rec.values("flags");
  ASSERT_GT(y.size(), 1000U) << "a second of loop time or more";
  double drift = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    EXPECT_NEAR(gy[i], y_mass * g, 1e-12);
    EXPECT_EQ(gx[i], 0.0);
    EXPECT_EQ(oy[i], gy[i]) << "the feedforward sent as it is, below the limit";
    EXPECT_EQ(flags[i], 0.0);
    drift = std::max(drift, std::abs(y[i]));
  }
  // The feedforward m g and the plant's weight "-2.941995" N differ by at most
  // a rounding of m g (4.4e-16 N); on 0.3 kg over 10 s that moves y by
  // 7e-14 m, below one count (1 nm): the reading stays within one count.
  EXPECT_LE(drift, resolution * 1.0001) << y.size() << " rows";
  std::printf("gravity: |y| at most %.3g m over %zu rows (%.3g s)\n", drift, y.size(),
              static_cast<double>(y.size()) * 1e-3);
  bool noted = false;
  for (const auto& c : rec.comments)
    noted = noted || c.find("gravity: 0.3 kg on axis y") != std::string::npos;
  EXPECT_TRUE(noted) << "the header says what the feedforward is";
}

TEST(Gravity, WithoutTheFeedforwardTheAxisFalls) {
  TempDir dir;
  Daemon daemon(dir, vertical_stage(""));
  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  EXPECT_FALSE(json::parse(status.out).contains("gravity"));
  const Recording rec = record_after(daemon, dir, {"axis=2", "mode=free"}, 400);
  EXPECT_FALSE(rec.has_column("gravity_y_n")) << "no gravity columns without [gravity]";
  EXPECT_FALSE(rec.has_column("workspace_penetration_m"));
  const auto y = rec.values("position_y_m");
  ASSERT_GT(y.size(), 200U);
  // 0.1 s after the release it has fallen g t^2 / 2 = 4.9 cm (the position
  // rule may latch an encoder jump later: the plant keeps falling).
  EXPECT_LT(*std::min_element(y.begin(), y.end()), -0.04);
  std::printf("no gravity: y down to %.3g m over %zu rows\n", *std::min_element(y.begin(), y.end()),
              y.size());
}

/// One vertical linear axis (0.3 kg, weighing -m g on the loopback), the
/// hand holding it at 0 to start; a wall far below, so the scene adds nothing.
std::string vertical_axis(const std::string& sections, const std::string& motion = "linear") {
  return "[loop]\nperiod = \"1ms\"\nclock = \"virtual\"\n"
         "[device]\ndriver = \"loopback\"\ntorque_limit = 10.0\n"
         "[device.loopback]\nmotion = \"" +
         motion +
         "\"\nmass = 0.3\ndamping = 0\ncounts = 1e9\naxis_weight = \"-2.941995\"\nhand = \"mode=hold\"\n"
         "[scene]\nname = \"wall\"\nstiffness = 1000\nposition = -1\nside = \"lower\"\n" +
         sections;
}

TEST(Gravity, OneVerticalAxisIsHeldByItsWeightAfterTheScene) {
  TempDir dir;
  Daemon daemon(dir, vertical_axis("[gravity]\nmass = 0.3\n"));
  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  const json st = json::parse(status.out);
  EXPECT_FALSE(st["gravity"].contains("axis")) << st.dump();
  EXPECT_EQ(st["gravity"]["mass"], 0.3);
  EXPECT_EQ(st["gravity"]["down"], "negative");
  EXPECT_NEAR(st["gravity"]["feedforward"].get<double>(), y_mass * g, 1e-12);

  const Recording rec = record_after(daemon, dir, {"mode=free"}, 400);
  ASSERT_TRUE(rec.has_column("gravity_n")) << "the feedforward recorded, in N";
  const auto x = rec.values("position_m"), gravity = rec.values("gravity_n");
  const auto applied = rec.values("applied_n"), flags = rec.values("flags");
  ASSERT_GT(x.size(), 1000U) << "a second of loop time or more";
  double drift = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    EXPECT_NEAR(gravity[i], y_mass * g, 1e-12);
    EXPECT_EQ(applied[i], gravity[i]) << "the wall far below adds nothing";
    EXPECT_EQ(flags[i], 0.0);
    drift = std::max(drift, std::abs(x[i]));
  }
  // As on the stage: m g and the loopback's -2.941995 N differ by a rounding.
  EXPECT_LE(drift, resolution * 1.0001) << x.size() << " rows";
  std::printf("gravity on one axis: |x| at most %.3g m over %zu rows\n", drift, x.size());
  bool noted = false;
  for (const auto& c : rec.comments)
    noted = noted || c.find("gravity: 0.3 kg on the axis") != std::string::npos;
  EXPECT_TRUE(noted) << "the header says what the feedforward is";
}

TEST(Gravity, OneVerticalAxisFallsWithoutTheFeedforward) {
  TempDir dir;
  Daemon daemon(dir, vertical_axis(""));
  const Recording rec = record_after(daemon, dir, {"mode=free"}, 400);
  EXPECT_FALSE(rec.has_column("gravity_n")) << "a one-axis recording as before without [gravity]";
  const auto x = rec.values("position_m");
  ASSERT_GT(x.size(), 200U);
  EXPECT_LT(*std::min_element(x.begin(), x.end()), -0.04) << "g t^2 / 2 = 4.9 cm after 0.1 s";
}

TEST(Gravity, AWorkspaceBoxHoldsTheDeviceInsideWhileTheHandPushesOut) {
  TempDir dir;
  const double k = 2000.0, push = 2.0;
  Daemon daemon(
      dir, vertical_stage(gravity_on_y +
                              "[workspace]\nshape = \"box\"\nlow = \"-0.01,-0.01\"\nhigh = \"0.01,0.01\"\n"
                              "stiffness = 2000\ndamping = 20\ndelay = 1\n",
                          "30.0"));  // above the impact's peak: nothing scales the feedforward
  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  const json st = json::parse(status.out);
  EXPECT_EQ(st["workspace"]["shape"], "box") << st.dump();
  EXPECT_EQ(st["workspace"]["parameters"]["stiffness"], 2000.0);
  EXPECT_TRUE(st["workspace"]["stability"]["stable"].get<bool>()) << st.dump();
  // Let go of y (gravity holds it) and push x outward with 2 N.
  ASSERT_EQ(daemon.ctl({"device", "call", "hand.set", "axis=2", "mode=free"}).exit_code, 0);
  const Recording rec = record_after(daemon, dir, {"axis=1", "mode=force", "force=2"}, 400);
  const auto x = rec.values("position_x_m"), y = rec.values("position_y_m");
  const auto penetration = rec.values("workspace_penetration_m"), fx = rec.values("force_x_n");
  ASSERT_GT(x.size(), 1000U);
  double deepest = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    deepest = std::max(deepest, x[i] - 0.01);
    EXPECT_LE(std::abs(y[i]), resolution * 1.0001) << "y held by gravity compensation";
    if (x[i] > 0.01) {
      EXPECT_NEAR(penetration[i], x[i] - 0.01, 1e-12) << "row " << i;
    }
  }
  // At rest against the face K p balances the hand: p = F / K = 1 mm. On
  // the way in the hand's work over the 1 cm approach, E = F d, goes into
  // the wall: K p^2 / 2 <= F p + E bounds the deepest point (5.6 mm; the
  // damping only lowers it).
  EXPECT_NEAR(x.back() - 0.01, push / k, 2e-6) << "one count and the damping's last wiggle";
  EXPECT_NEAR(fx.back(), -push, 5e-3);
  EXPECT_LT(deepest, push / k + std::sqrt(std::pow(push / k, 2) + 2 * push * 0.01 / k));
  EXPECT_GT(deepest, push / k) << "it did push into the wall";
  std::printf("workspace: deepest %.4g m, at rest %.6g m outside, over %zu rows\n", deepest, x.back() - 0.01,
              x.size());
}

/// The loopback pantograph of the default links in a vertical plane: its
/// links and handle weigh 0.02, 0.03, 0.03, 0.02 and 0.01 kg; the hand holds
/// the handle at the workspace's centre to start; 1e9 counts a revolution.
std::string vertical_pantograph(const std::string& sections, const std::string& torque_limit = "1.0") {
  return "[loop]\nperiod = \"1ms\"\nclock = \"virtual\"\n"
         "[device]\ndriver = \"loopback\"\nkinematics = \"pantograph\"\ntorque_limit = " +
         torque_limit +
         "\n[device.loopback]\nlinkage = \"pantograph\"\ncounts = 1e9\n"
         "link_masses = \"0.02,0.03,0.03,0.02,0.01\"\nhand = \"mode=hold\"\n"
         "[scene]\nname = \"free\"\n" +
         sections;
}

const std::string gravity_of_the_links =
    "[gravity]\nlink_masses = [0.02, 0.03, 0.03, 0.02]\nhandle_mass = 0.01\n";

TEST(Gravity, TheFeedforwardHoldsThePantographsLinksStillWhenTheHandLetsGo) {
  TempDir dir;
  Daemon daemon(dir, vertical_pantograph(gravity_of_the_links));
  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  const json st = json::parse(status.out);
  EXPECT_EQ(st["gravity"]["link_masses"], json::parse("[0.02, 0.03, 0.03, 0.02]")) << st.dump();
  EXPECT_EQ(st["gravity"]["handle_mass"], 0.01);
  const double worst = st["gravity"]["worst_case"]["torque"].get<double>();
  EXPECT_GT(worst, 0.0);
  EXPECT_LT(worst, 1.0) << "within the torque limit, or the config is refused";

  // 1.5 s of real time: tens of seconds of loop time on the virtual clock,
  // even under ASan beside another test (19,456 rows in 0.4 s there).
  const Recording rec = record_after(daemon, dir, {"mode=free"}, 1500);
  const auto hx = rec.values("handle_x_m"), hy = rec.values("handle_y_m"), q1 = rec.values("position_q1_rad");
  const auto g1 = rec.values("gravity_q1_n_m"), o1 = rec.values("output_q1_n_m"), flags = rec.values("flags");
  ASSERT_GT(hy.size(), 12000U) << "12 s of loop time or more";
  // The first row the joints moved in: the hand let go just before.
  std::size_t moved = 0;
  while (moved < q1.size() && q1[moved] == q1[0]) ++moved;
  ASSERT_LT(moved + 10000, q1.size()) << "10 s of loop time after the hand let go";
  double early = 0.0, drift = 0.0, largest = 0.0;
  for (std::size_t i = 0; i < hy.size(); ++i) {
    EXPECT_EQ(o1[i], g1[i]) << "the feedforward sent as it is, below the limit";
    EXPECT_EQ(flags[i], 0.0) << "row " << i;
    const double d = std::hypot(hx[i] - 0.02, hy[i] - 0.095);
    if (i <= moved + 10000) early = std::max(early, d);
    drift = std::max(drift, d);
    largest = std::max(largest, std::abs(g1[i]));
  }
  EXPECT_GT(largest, 1e-3) << "the links do weigh";
  EXPECT_LE(largest, worst * (1 + 1e-9)) << "the worst case over the workspace bounds it";
  // The feedforward is the plant's weight at the joints read: the encoder
  // reads up to one count (6 nrad) below the angle, so the joints feel a
  // residual of about dtau/dq x 3 nrad, 1e-10 N m. On frictionless joints in
  // neutral equilibrium it drifts as t^2: within 1 um over the first 10 s.
  EXPECT_LE(early, 1e-6) << "over the 10 s after the hand let go";
  std::printf(
      "pantograph gravity: the handle within %.3g m over 10 s after the release, %.3g m over %zu rows "
      "(%.0f s); holding torque up to %.4g N m\n",
      early, drift, hy.size(), static_cast<double>(hy.size()) * 1e-3, largest);
}

TEST(Gravity, TheConfigsGravityAndWorkspaceErrorsNameTheKeyAndTheLimit) {
  TempDir dir;
  const auto config = dir.path / "bad.toml";
  const auto check = [&](const std::string& text) {
    std::FILE* f = std::fopen(config.c_str(), "w");
    std::fputs(text.c_str(), f);
    std::fclose(f);
    return run(hapticd_binary(), {"--check-config", "-c", config.string()});
  };
  const auto expect_error = [&](const std::string& text, const std::string& wanted) {
    const auto r = check(text);
    EXPECT_EQ(r.exit_code, 2) << r.out;
    EXPECT_NE(r.err.find(wanted), std::string::npos) << r.err;
    return r.err;
  };
  // A wall too stiff for the 0.1 kg x axis: refused along that axis, naming the limit.
  const std::string stiff = expect_error(
      vertical_stage("[workspace]\nshape = \"box\"\nstiffness = 1e6\ndamping = 46\ndelay = 1\n"),
      "bad.toml:18:13: workspace (box): box along axis x (m_n = 0.1 kg, damping 0 N s/m, exact): unstable");
  EXPECT_NE(stiff.find("the largest stable K is 14447 N/m"), std::string::npos) << stiff;
  EXPECT_NE(stiff.find("accepted: a workspace wall the gate holds"), std::string::npos) << stiff;
  expect_error(vertical_stage("[workspace]\nshape = \"sphere\"\nradius = -1\n"),
               "bad.toml:18:10: workspace (sphere): ");
  expect_error(vertical_stage("[workspace]\nshape = \"cube\"\n"),
               "workspace.shape = \"cube\" is out of range; accepted: \"box\" or \"sphere\"");
  expect_error(vertical_stage("[workspace]\nshape = \"sphere\"\nside = \"outside\"\n"),
               "workspace.side: a workspace holds the device inside its sphere");
  expect_error(vertical_stage("[gravity]\naxis = \"z\"\nmass = 0.3\n"),
               "bad.toml:17:8: gravity.axis = \"z\" names no axis of the device; accepted: x, y");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\nmass = 2\n"),
               "gravity.mass = 2 kg weighs 19.61 N, more than the torque limit of axis y, 10 N");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\nmass = -1\n"),
               "gravity.mass = -1 is out of range; accepted: a mass in kg greater than 0 and at most 100");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\nmass = nan\n"), "gravity.mass");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\n"), "[gravity] needs mass (kg)");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\nmass = 0.3\nacceleration = 100\n"),
               "gravity.acceleration = 100 is out of range");
  expect_error(vertical_axis("[gravity]\naxis = \"x\"\nmass = 0.1\n"),
               "gravity.axis names a stage's vertical axis; this device has one axis, which [gravity] "
               "holds; accepted: mass and down without axis");
  expect_error(vertical_axis("[gravity]\nmass = 0.3\n", "rotary"),
               "[gravity] on one axis is a constant weight on a vertical linear axis; this device is rotary");
  expect_error(vertical_axis("[gravity]\nmass = 2\n"),
               "gravity.mass = 2 kg weighs 19.61 N, more than the torque limit 10 N");
  expect_error(vertical_axis("[workspace]\nshape = \"box\"\n"),
               "[workspace] is a box or a sphere in the task space of a device with several axes; this one "
               "(loopback) has one");
  expect_error(vertical_stage("[gravity]\nmass = 0.3\n"),
               "[gravity] on a stage with several axes needs axis (the vertical axis' name); accepted: x, y");
  expect_error(vertical_pantograph("[gravity]\nlink_masses = [1, 1, 1, 1]\n"),
               "gravity.link_masses: holding the links takes up to ");
  expect_error(vertical_pantograph("[gravity]\naxis = \"q1\"\nmass = 0.1\n"),
               "[gravity] on the pantograph: its weight is in its links; accepted: link_masses");
  expect_error(vertical_pantograph("[gravity]\nlink_masses = [0.1, 0.1, 0.1]\n"),
               "gravity.link_masses = [...] is out of range; accepted: four masses in kg");
  expect_error(vertical_pantograph("[gravity]\nlink_masses = [0.1, 0.1, 0.1, 0.1]\naxis = \"q1\"\n"),
               "[gravity] gives both a stage's axis, mass or down and the pantograph's link_masses");
  expect_error(vertical_stage("[gravity]\nlink_masses = [0.1, 0.1, 0.1, 0.1]\n"),
               "gravity.link_masses is for the pantograph");
  expect_error(vertical_stage("[gravity]\naxis = \"y\"\nmass = 0.3\nhandle_mass = 0.1\n"),
               "gravity.handle_mass goes with link_masses");
  const auto fine = check(vertical_stage(gravity_on_y + "[workspace]\nshape = \"sphere\"\nradius = 0.02\n"
                                                        "stiffness = 2000\ndamping = 20\n"));
  EXPECT_EQ(fine.exit_code, 0) << fine.err;
  EXPECT_NE(fine.out.find("gravity: 0.3 kg on axis y"), std::string::npos) << fine.out;
  EXPECT_NE(fine.out.find("workspace: sphere"), std::string::npos) << fine.out;
  const auto one_axis = check(vertical_axis("[gravity]\nmass = 0.3\ndown = \"positive\"\n"));
  EXPECT_EQ(one_axis.exit_code, 0) << one_axis.err;
  EXPECT_NE(
      one_axis.out.find("gravity: 0.3 kg on the axis (down positive, g = 9.807 m/s^2): a feedforward of "
                        "-2.942 N"),
      std::string::npos)
      << one_axis.out;
}

}  // namespace
}  // namespace hapticd::e2e::gravity_test
