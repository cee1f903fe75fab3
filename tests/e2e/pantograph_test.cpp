// End-to-end, the pantograph (issue 22): the real hapticd on the loopback's
// five-bar linkage (two rotary joints, the hand on the handle; virtual
// clock) and the real hapticctl. --check-config and a refused scene.load
// show the gate's bound with its worst-case configuration, the same figure
// `hapticctl analyze plane-wall --pantograph` gives; a plane wall and a
// sphere are recorded while the hand moves the handle through them, and
// every row's task force is the wall's law along n (the radius) at the
// handle the kinematics put there; a hand spring pushing into the wall
// settles where the two springs balance, the device bounded.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "support.hpp"

namespace hapticd::e2e::pantograph_test {
namespace {

using nlohmann::json;

constexpr double k_wall = 1000.0;
constexpr double b_wall = 2.0;
constexpr double period = 1e-3;
constexpr double start_x = 0.02, start_y = 0.095;  // the default workspace's centre, m

std::string pantograph_config(const std::string& scene = "[scene]\nname = \"free\"\n") {
  return "[loop]\nperiod = \"1ms\"\nclock = \"virtual\"\n"
         "[device]\ndriver = \"loopback\"\ntorque_limit = 1.0\nkinematics = \"pantograph\"\n"
         "[device.loopback]\nlinkage = \"pantograph\"\njoint_inertia = \"0.0005,0.0005\"\n"
         // The handle moved along y, 8 mm either side of the centre, at 1 Hz.
         "hand = \"direction=0,1 mode=hold trajectory=sine amplitude=0.008 frequency=1\"\n" +
         scene;
}

double number_after(const std::string& text, const std::string& prefix) {
  const auto at = text.find(prefix);
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + prefix.size()));
}

/// Each joint reads up to one count (2 pi / 16384 rad) below its angle; x
/// and y move by at most |J_i1| + |J_i2| per radian of both, below 0.13
/// m/rad over the default workspace (0.100 for x, 0.130 for y on a 41 x 41
/// grid): the handle reads within 50 um of where it is.
constexpr double handle_count_m = 0.13 * 2 * 3.141592653589793 / 16384;

TEST(Pantograph, CheckConfigShowsTheGatesBoundWithItsWorstCaseConfiguration) {
  TempDir dir;
  const auto config = dir.path / "p.toml";
  std::FILE* f = std::fopen(config.c_str(), "w");
  std::fputs(pantograph_config("[scene]\nname = \"plane-wall\"\nnormal = \"0,-1\"\noffset = -0.1\n"
                               "stiffness = 1000.0\ndamping = 2.0\ndelay = 0\n")
                 .c_str(),
             f);
  std::fclose(f);
  const auto checked = run(hapticd_binary(), {"--check-config", "-c", config.string()});
  ASSERT_EQ(checked.exit_code, 0) << checked.err;
  EXPECT_NE(checked.out.find("axes: pantograph q1 (0.0005 kg m^2, 0 N m s/rad), q2 (0.0005 kg m^2, 0 N m "
                             "s/rad); links 0.07, 0.09, 0.09, 0.07, 0.0381 m; workspace x -0.02 to 0.06 m, "
                             "y 0.07 to 0.12 m"),
            std::string::npos)
      << checked.out;
  EXPECT_NE(checked.out.find("stability: along the normal (0, -1), its worst case at ("), std::string::npos)
      << checked.out;
  EXPECT_NE(checked.out.find("a bound, not exact): stable"), std::string::npos) << checked.out;
}

TEST(Pantograph, APlaneWallAndASphereOnTheLoopbackPantograph) {
  TempDir dir;
  Daemon daemon(dir, pantograph_config());

  const auto status = daemon.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err << daemon.log();
  const json st = json::parse(status.out);
  EXPECT_EQ(st["device"]["kinematics"], "pantograph");
  ASSERT_EQ(st["device"]["axes"].size(), 2U) << st.dump();
  EXPECT_EQ(st["device"]["axes"][0]["name"], "q1");

  // Refused with the bound along n and its configuration; the limit is the
  // one `hapticctl analyze plane-wall --pantograph` finds for that bound.
  const auto refused = daemon.ctl(
      {"load", "plane-wall", "normal=0,-1", "offset=-0.1", "stiffness=1e6", "damping=2", "delay=0"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("plane-wall along the normal (0, -1), its worst case at ("), std::string::npos)
      << refused.err;
  EXPECT_NE(refused.err.find("a bound, not exact"), std::string::npos) << refused.err;
  const auto bound = run(hapticctl_binary(),
                         {"analyze", "plane-wall", "--normal", "0,-1", "--pantograph",
                          "0.07,0.09,0.09,0.07,0.0381", "--joint-inertia", "0.0005,0.0005", "--workspace",
                          "-0.02,0.06,0.07,0.12", "--period", "1ms", "--delay", "0", "--json"});
  ASSERT_EQ(bound.exit_code, 0) << bound.err;
  const json b = json::parse(bound.out);
  EXPECT_NEAR(number_after(refused.err, "m_n = "), b["mass_along_normal"].get<double>(),
              1e-3 * b["mass_along_normal"].get<double>())
      << refused.err;
  EXPECT_NEAR(number_after(refused.err, "the largest stable K is "), b["k_max"].get<double>(),
              1e-3 * b["k_max"].get<double>())
      << refused.err << "\n"
      << b.dump();

  // The plane wall at y = 0.1 m, its free side below; the hand reaches 3 mm in.
  const auto loaded = daemon.ctl(
      {"load", "plane-wall", "normal=0,-1", "offset=-0.1", "stiffness=1000", "damping=2", "delay=0"});
  ASSERT_EQ(loaded.exit_code, 0) << loaded.err;
  ASSERT_EQ(daemon.ctl({"record", "start", "--path", "plane.csv"}).exit_code, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(daemon.ctl({"record", "stop"}).exit_code, 0) << daemon.log();

  // The sphere around the centre, the handle kept inside: the hand reaches 2 mm out.
  ASSERT_EQ(daemon
                .ctl({"load", "sphere", "center=0.02,0.095", "radius=0.006", "side=inside", "stiffness=1000",
                      "damping=2", "delay=0"})
                .exit_code,
            0);
  ASSERT_EQ(daemon.ctl({"record", "start", "--path", "sphere.csv"}).exit_code, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(daemon.ctl({"record", "stop"}).exit_code, 0) << daemon.log();

  // The hand as a 200 N/m spring to a point 1 cm inside the plane wall.
  ASSERT_EQ(
      daemon
          .ctl({"load", "plane-wall", "normal=0,-1", "offset=-0.1", "stiffness=1000", "damping=2", "delay=0"})
          .exit_code,
      0);
  const auto hand = daemon.ctl({"device", "call", "hand.set", "mode=impedance", "stiffness=200", "damping=2",
                                "direction=0,1", "trajectory=constant", "position=0.015"});
  ASSERT_EQ(hand.exit_code, 0) << hand.err;
  ASSERT_EQ(daemon.ctl({"record", "start", "--path", "push.csv"}).exit_code, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  ASSERT_EQ(daemon.ctl({"record", "stop"}).exit_code, 0) << daemon.log();
  const auto after = json::parse(daemon.ctl({"status", "--json"}).out);
  EXPECT_TRUE(after["fault"].is_null()) << after.dump();
  ASSERT_EQ(daemon.stop(), 0) << daemon.log();

  {
    const Recording rec = read_recording(dir.path / "plane.csv");
    const auto x = rec.values("handle_x_m"), y = rec.values("handle_y_m");
    const auto fx = rec.values("force_x_n"), fy = rec.values("force_y_n");
    const auto penetration = rec.values("penetration_m"), flags = rec.values("flags");
    ASSERT_GT(x.size(), 1000U);
    int pushing = 0;
    bool armed = false;
    for (std::size_t i = 1; i < x.size(); ++i) {
      const double s = -y[i], s_before = -y[i - 1];  // n . x with n = (0, -1)
      const double depth = -0.1 - s;
      if (!armed && depth > 0.0) continue;
      armed = true;
      // Hulin's law on n . x at the handle the kinematics put there, along n.
      const double along =
          depth > 0.0 ? std::max(0.0, k_wall * depth - b_wall * (s - s_before) / period) : 0.0;
      ASSERT_NEAR(fx[i], 0.0, 1e-12) << "row " << i;
      ASSERT_NEAR(fy[i], -along, 1e-9) << "row " << i;
      EXPECT_NEAR(penetration[i], depth, 1e-12) << "signed: < 0 outside";
      // The hand holds x at the centre: the handle read there to the encoders' count.
      EXPECT_NEAR(x[i], start_x, handle_count_m) << "row " << i;
      EXPECT_LE(y[i], start_y + 0.008 + handle_count_m);
      EXPECT_EQ(flags[i], 0.0);
      pushing += along > 0.0 ? 1 : 0;
    }
    EXPECT_GT(pushing, 100);
  }
  {
    const Recording rec = read_recording(dir.path / "sphere.csv");
    const auto x = rec.values("handle_x_m"), y = rec.values("handle_y_m");
    const auto fx = rec.values("force_x_n"), fy = rec.values("force_y_n");
    const auto penetration = rec.values("penetration_m");
    ASSERT_GT(x.size(), 1000U);
    int pushing = 0;
    bool armed = false;
    for (std::size_t i = 1; i < x.size(); ++i) {
      const double dx = x[i] - start_x, dy = y[i] - start_y;
      const double r = std::hypot(dx, dy), r_before = std::hypot(x[i - 1] - start_x, y[i - 1] - start_y);
      const double depth = r - 0.006;
      if (!armed && depth > 0.0) continue;
      armed = true;
      // Towards the centre, K times the depth plus B on the radial speed, never pulling.
      const double along =
          depth > 0.0 ? std::max(0.0, k_wall * depth + b_wall * (r - r_before) / period) : 0.0;
      ASSERT_NEAR(fx[i], -along * dx / r, 1e-9) << "row " << i;
      ASSERT_NEAR(fy[i], -along * dy / r, 1e-9) << "row " << i;
      EXPECT_NEAR(penetration[i], depth, 1e-12) << "signed: < 0 inside the ball";
      pushing += along > 0.0 ? 1 : 0;
    }
    EXPECT_GT(pushing, 100);
  }
  {
    // The hand's spring and the wall balance: K_h (0.11 - y) = K (y - 0.1).
    const Recording rec = read_recording(dir.path / "push.csv");
    const auto y = rec.values("handle_y_m"), fy = rec.values("force_y_n");
    const auto penetration = rec.values("penetration_m");
    ASSERT_GT(y.size(), 200U);
    double deepest = 0.0;
    for (const double p : penetration) deepest = std::max(deepest, p);
    const double settled = 200.0 * 0.01 / (200.0 + k_wall);  // 1.67 mm
    EXPECT_LT(deepest, 3 * settled) << "bounded: the spring's overshoot, no growth";
    EXPECT_NEAR(penetration.back(), settled, 2 * handle_count_m);
    EXPECT_NEAR(fy.back(), -k_wall * penetration.back(), 0.05) << "at rest: K times the penetration";
  }
}

}  // namespace
}  // namespace hapticd::e2e::pantograph_test
