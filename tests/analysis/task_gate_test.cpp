// The stability gate in task space (analysis/task_gate.hpp, issue 22): a
// plane wall is judged along its normal with the device's m_n, so its limit
// there is the one-axis Hulin limit with m_n (what `hapticctl analyze wall
// --mass m_n` says), for several normals and masses; a sphere along the
// lightest axis; a box on each face's axis; refusals name the direction or
// axis and the limit; a device whose axes cannot be judged gets no verdict.

#include "analysis/task_gate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/wall_stability.hpp"

namespace task_gate_test {

namespace {

using namespace hapticd::analysis;
namespace world = hapticd::world;

constexpr double period = 1e-3;

GateDevice stage(std::vector<JointModel> axes, int delay = 0) {
  GateDevice device =
      rigid_device(axes.front().mass, axes.front().damping, period, delay, world::Motion::linear);
  device.axes = std::move(axes);
  const std::vector<std::string> names{"x", "y", "z", "a", "b", "c"};
  device.axis_names.assign(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(device.axes.size()));
  return device;
}

world::AxisVector direction(std::vector<double> v) {
  world::AxisVector out(static_cast<Eigen::Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) out(static_cast<Eigen::Index>(i)) = v[i];
  return out;
}

std::string text_of(const std::vector<double>& v) {
  std::ostringstream out;
  for (std::size_t i = 0; i < v.size(); ++i) out << (i > 0 ? "," : "") << v[i];
  return out.str();
}

/// The plane wall's refusal, planned on `device` with K far above any limit.
GateRefusal refused_plane(const GateDevice& device, const std::vector<double>& normal, double damping,
                          int delay) {
  const auto outcome = gate_scene("plane-wall",
                                  {{"normal", text_of(normal)},
                                   {"stiffness", 1e7},
                                   {"damping", damping},
                                   {"delay", static_cast<double>(delay)}},
                                  device, false);
  EXPECT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  return std::holds_alternative<GateRefusal>(outcome) ? std::get<GateRefusal>(outcome) : GateRefusal{};
}

TEST(TaskGate, APlaneWallsLimitAlongItsNormalIsTheOneAxisHulinLimitWithMn) {
  struct Case {
    std::vector<JointModel> axes;
    std::vector<double> normal;
    int delay;
  };
  const std::vector<Case> cases{
      {{{0.1, 0.0}, {0.3, 0.0}}, {1, 1}, 1},                  // the issue's: m_n = 0.15 kg
      {{{0.1, 0.0}, {0.3, 0.0}}, {1, -2}, 0},                 // another normal
      {{{0.5, 0.0}, {0.2, 0.0}}, {3, 1}, 2},                  // other masses
      {{{0.05, 0.0}, {0.4, 0.0}, {1.0, 0.0}}, {1, 2, 3}, 1},  // three axes
  };
  for (const Case& c : cases) {
    const GateDevice device = stage(c.axes);
    const DirectionalModel along = cartesian_along(c.axes, direction(c.normal));
    double inverse = 0.0;
    const double norm2 = [&] {
      double s = 0.0;
      for (const double x : c.normal) s += x * x;
      return s;
    }();
    for (std::size_t i = 0; i < c.axes.size(); ++i)
      inverse += c.normal[i] * c.normal[i] / norm2 / c.axes[i].mass;
    ASSERT_NEAR(along.mass, 1.0 / inverse, 1e-15);
    const double b = 46.0;
    const GateRefusal refusal = refused_plane(device, c.normal, b, c.delay);
    SCOPED_TRACE(refusal.message);
    // `hapticctl analyze wall --mass m_n --period 1ms --delay d --damping B`:
    const WallVerdict one_axis = analyze_wall(along.mass, period, c.delay, 1e7, b);
    ASSERT_TRUE(refusal.hulin.has_value()) << "an undamped rigid stage: Hulin's region is said";
    // (the plan's normal is normalized once more by cartesian_along: m_n to the last bits)
    EXPECT_NEAR(refusal.hulin->k_max / one_axis.k_max, 1.0, 1e-12) << "the largest K for any B, with m_n";
    ASSERT_TRUE(refusal.stiffness_limit.has_value());
    EXPECT_NEAR(*refusal.stiffness_limit / one_axis.k_max_for_damping, 1.0, 1e-5)
        << "the largest K at this B";
    EXPECT_NE(refusal.message.find("plane-wall along the normal ("), std::string::npos);
    EXPECT_NE(refusal.message.find("exact"), std::string::npos) << "undamped: proportional (0 = 0 m)";
    // Just under the limit is accepted, just over refused.
    const auto at = [&](double k) {
      return gate_scene("plane-wall",
                        {{"normal", text_of(c.normal)},
                         {"stiffness", k},
                         {"damping", b},
                         {"delay", static_cast<double>(c.delay)}},
                        device, false);
    };
    EXPECT_TRUE(std::holds_alternative<GateAccepted>(at(0.999 * *refusal.stiffness_limit)));
    EXPECT_TRUE(std::holds_alternative<GateRefusal>(at(1.001 * *refusal.stiffness_limit)));
  }
}

TEST(TaskGate, TheIssuesNumbersAlongOneOne) {
  const GateDevice device = stage({{0.1, 0.0}, {0.3, 0.0}});
  const GateRefusal refusal = refused_plane(device, {1, 1}, 46.0, 1);
  EXPECT_TRUE(
      refusal.message.starts_with("plane-wall along the normal (0.7071, 0.7071) (m_n = 0.15 kg, damping 0 N "
                                  "s/m, exact): unstable on this "
                                  "device (m = 0.15 kg, T = 1 ms, d = 0): pole radius"))
      << refusal.message;
  // Hulin's d = 1 alpha_max = 0.144469 with m = 0.15 kg, T = 1 ms.
  EXPECT_NEAR(refusal.hulin->k_max, 0.144469349226 * 0.15 / (period * period), 1e-3);
}

TEST(TaskGate, TheDeviceDelayAddsToTheWallsAlongTheNormalToo) {
  const GateDevice device = stage({{0.1, 0.0}, {0.3, 0.0}}, 1);
  const GateRefusal refusal = refused_plane(device, {1, 1}, 46.0, 0);
  EXPECT_NEAR(refusal.hulin->k_max / analyze_wall(0.15, period, 1, 1e7, 46.0).k_max, 1.0, 1e-12);
}

TEST(TaskGate, DampingNotProportionalToTheMassIsABound) {
  const GateDevice device = stage({{0.1, 1.0}, {0.3, 9.0}});  // 10 and 30 per kg
  const auto outcome = gate_scene("plane-wall", {{"normal", "1,1"}, {"stiffness", 2000.0}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateAccepted>(outcome));
  const auto& accepted = std::get<GateAccepted>(outcome);
  EXPECT_NE(accepted.stability.summary.find("damping 1.5 N s/m, a bound"), std::string::npos)
      << accepted.stability.summary;
  const GateDevice proportional = stage({{0.1, 1.0}, {0.3, 3.0}});
  const auto exact =
      gate_scene("plane-wall", {{"normal", "1,1"}, {"stiffness", 2000.0}}, proportional, false);
  EXPECT_NE(std::get<GateAccepted>(exact).stability.summary.find("damping 1.5 N s/m, exact"),
            std::string::npos)
      << std::get<GateAccepted>(exact).stability.summary;
}

TEST(TaskGate, ASphereIsJudgedAlongTheLightestAxis) {
  const GateDevice device = stage({{0.3, 0.0}, {0.1, 0.0}, {0.2, 0.0}});
  const auto outcome = gate_scene("sphere", {{"stiffness", 1e7}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  const auto& refusal = std::get<GateRefusal>(outcome);
  EXPECT_EQ(refusal.message.substr(0, 66),
            "sphere along the worst direction (the lightest axis, y) (m_n = 0.1");
  EXPECT_EQ(refusal.hulin->k_max, analyze_wall(0.1, period, 1, 1e7, 46.0).k_max);
}

TEST(TaskGate, ABoxIsJudgedOnEachAxisAndRefusedNamingTheWeakest) {
  const GateDevice device = stage({{0.3, 0.0}, {0.1, 0.0}});
  const double k_y = analyze_wall(0.1, period, 1, 1e7, 46.0).k_max_for_damping;
  const double k_x = analyze_wall(0.3, period, 1, 1e7, 46.0).k_max_for_damping;
  ASSERT_LT(k_y, k_x);
  const auto between = gate_scene("box", {{"stiffness", 0.5 * (k_x + k_y)}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(between));
  const auto& refusal = std::get<GateRefusal>(between);
  EXPECT_EQ(refusal.message.substr(0, 29), "box along axis y (m_n = 0.1 k") << refusal.message;
  EXPECT_NEAR(*refusal.stiffness_limit / k_y, 1.0, 1e-5);
  const auto under = gate_scene("box", {{"stiffness", 0.99 * k_y}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateAccepted>(under));
  EXPECT_NE(std::get<GateAccepted>(under).stability.summary.find("(the worst of 2 axes)"), std::string::npos);
  const auto forced = gate_scene("box", {{"stiffness", 0.5 * (k_x + k_y)}}, device, true);
  ASSERT_TRUE(std::holds_alternative<GateAccepted>(forced));
  EXPECT_TRUE(std::get<GateAccepted>(forced).forced);
}

TEST(TaskGate, AxesThatCannotBeJudgedGiveNoVerdictEvenForced) {
  for (const double mass : {0.0, std::nan(""), HUGE_VAL}) {
    const GateDevice device = stage({{0.1, 0.0}, {mass, 0.0}});
    const auto outcome = gate_scene("plane-wall", {{"normal", "1,1"}}, device, true);
    ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome)) << mass;
    const auto& refusal = std::get<GateRefusal>(outcome);
    EXPECT_FALSE(refusal.assessed);
    EXPECT_NE(refusal.message.find("cannot be assessed"), std::string::npos) << refusal.message;
  }
  GateDevice one_axis = rigid_device(0.1, 0.0, period, 0, world::Motion::linear);
  const auto outcome = gate_scene("plane-wall", {}, one_axis, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  EXPECT_TRUE(std::get<GateRefusal>(outcome).invalid) << "a one-axis device refuses a task scene";
}

}  // namespace

// ---- the pantograph: the worst case over the workspace, a bound ----

namespace {

GateDevice pantograph(std::vector<JointModel> joints, const TaskBox& box) {
  GateDevice device =
      rigid_device(joints.front().mass, joints.front().damping, period, 0, world::Motion::rotary);
  device.axes = std::move(joints);
  device.axis_names = {"q1", "q2"};
  device.pantograph = world::PantographKinematics(world::PantographGeometry{});
  device.workspace = box;
  return device;
}

}  // namespace

TEST(TaskGate, APantographsPlaneWallIsJudgedAtItsLightestConfigurationAndSaysItIsABound) {
  const TaskBox box{-0.02, 0.06, 0.07, 0.12};
  for (const auto& joints : {std::vector<JointModel>{{5e-4, 0.0}, {5e-4, 0.0}},
                             std::vector<JointModel>{{3e-4, 0.0}, {8e-4, 0.0}}}) {
    for (const auto& normal : {std::vector<double>{0, -1}, std::vector<double>{1, 1}}) {
      const GateDevice device = pantograph(joints, box);
      const DirectionalModel worst = pantograph_along(*device.pantograph, joints, direction(normal), box);
      const GateRefusal refusal = refused_plane(device, normal, 1.0, 1);
      SCOPED_TRACE(refusal.message);
      // The limit is the one-axis limit with the worst case's m_n.
      const WallVerdict one_axis = analyze_wall(worst.mass, period, 1, 1e7, 1.0);
      ASSERT_TRUE(refusal.hulin.has_value());
      EXPECT_NEAR(refusal.hulin->k_max / one_axis.k_max, 1.0, 1e-9);
      EXPECT_NE(refusal.message.find("a bound, not exact"), std::string::npos);
      EXPECT_NE(refusal.message.find("its worst case at ("), std::string::npos) << "with the configuration";
      // The bound is the worst case: no configuration of the box is lighter along n.
      const world::PantographKinematics k{world::PantographGeometry{}};
      const world::AxisVector n = direction(normal).normalized();
      for (int i = 0; i <= 10; ++i) {
        for (int j = 0; j <= 10; ++j) {
          world::AxisVector x(2);
          x << box.x_min + (box.x_max - box.x_min) * i / 10, box.y_min + (box.y_max - box.y_min) * j / 10;
          world::TaskState s;
          k.solve(*k.inverse(x), s);
          const world::AxisVector jt_n = s.jacobian.transpose() * n;
          const double m_n = 1.0 / (jt_n(0) * jt_n(0) / joints[0].mass + jt_n(1) * jt_n(1) / joints[1].mass);
          EXPECT_GE(m_n, worst.mass * (1 - 1e-12)) << "at " << x.transpose();
        }
      }
    }
  }
}

TEST(TaskGate, APantographsSphereIsJudgedAlongTheLightestDirectionAnywhere) {
  const TaskBox box{-0.02, 0.06, 0.07, 0.12};
  const std::vector<JointModel> joints{{5e-4, 0.0}, {5e-4, 0.0}};
  const GateDevice device = pantograph(joints, box);
  world::AxisVector n;
  const DirectionalModel lightest = pantograph_lightest(*device.pantograph, joints, box, n);
  // Lighter than along any one direction's worst case.
  for (const auto& d : {std::vector<double>{1, 0}, std::vector<double>{0, 1}, std::vector<double>{1, 1}}) {
    EXPECT_LE(lightest.mass,
              pantograph_along(*device.pantograph, joints, direction(d), box).mass * (1 + 1e-9));
  }
  EXPECT_NEAR(pantograph_along(*device.pantograph, joints, n, box).mass / lightest.mass, 1.0, 1e-3)
      << "along its own direction the worst case is the same configuration";
  const auto outcome =
      gate_scene("sphere", {{"stiffness", 1e7}, {"damping", 1.0}, {"delay", 1.0}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  const auto& refusal = std::get<GateRefusal>(outcome);
  EXPECT_NE(refusal.message.find("the lightest direction ("), std::string::npos) << refusal.message;
  EXPECT_NEAR(refusal.hulin->k_max / analyze_wall(lightest.mass, period, 1, 1e7, 1.0).k_max, 1.0, 1e-9);
}

TEST(TaskGate, APantographWorkspaceOutOfReachCannotBeAssessed) {
  const GateDevice device = pantograph({{5e-4, 0.0}, {5e-4, 0.0}}, TaskBox{-0.02, 0.06, 0.07, 0.3});
  const auto outcome = gate_scene("plane-wall", {{"normal", "0,1"}, {"stiffness", 100.0}}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  EXPECT_FALSE(std::get<GateRefusal>(outcome).assessed);
  EXPECT_NE(std::get<GateRefusal>(outcome).message.find("out of the pantograph's reach"), std::string::npos);
}

// ---- axis-springs: spring-mass judged on each axis with its own mass ----

TEST(TaskGate, AxisSpringsIsJudgedPerAxisExactlyAndRefusedNamingTheAxisAndItsLimit) {
  // Undamped spring-mass with forward Euler grows on any mass; the exact
  // integrator with relative damping is stable up to a limit that depends
  // on the axis' mass: the lighter axis fails first.
  const GateDevice device = stage({{0.3, 0.0}, {0.05, 0.0}, {1.0, 0.0}});
  const world::ParameterSet springs{{"stiffness", 5e4}, {"mass", 0.5}, {"damping", 30.0}};
  const auto outcome = gate_scene("axis-springs", springs, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome)) << "K = 5e4 N/m with B = 30 on 0.05 kg";
  const GateRefusal& refusal = std::get<GateRefusal>(outcome);
  EXPECT_TRUE(refusal.message.starts_with(
      "axis-springs on axis y (m = 0.05 kg, b = 0 N s/m, exact: the axes decouple): "))
      << refusal.message;
  // The limit is the one-axis gate's for spring-mass on that axis alone.
  const auto alone =
      gate_scene("spring-mass", springs, rigid_device(0.05, 0.0, period, 0, world::Motion::linear), false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(alone));
  const GateRefusal& one_axis = std::get<GateRefusal>(alone);
  ASSERT_TRUE(one_axis.stiffness_limit.has_value());
  ASSERT_TRUE(refusal.stiffness_limit.has_value());
  EXPECT_EQ(*refusal.stiffness_limit, *one_axis.stiffness_limit);
  EXPECT_EQ(refusal.message.substr(refusal.message.find("decouple): ") + 11), one_axis.message.substr(13))
      << "the one-axis reason after 'spring-mass: '";
  // Each axis exactly: accepted iff every axis alone accepts it.
  for (const double k : {0.5 * *one_axis.stiffness_limit, 0.99 * *one_axis.stiffness_limit,
                         1.01 * *one_axis.stiffness_limit}) {
    world::ParameterSet at = springs;
    at["stiffness"] = k;
    bool every_axis = true;
    for (const double m : {0.3, 0.05, 1.0}) {
      every_axis = every_axis &&
                   std::holds_alternative<GateAccepted>(gate_scene(
                       "spring-mass", at, rigid_device(m, 0.0, period, 0, world::Motion::linear), false));
    }
    EXPECT_EQ(std::holds_alternative<GateAccepted>(gate_scene("axis-springs", at, device, false)), every_axis)
        << "K = " << k;
  }
  // The heaviest axis is named when it is the one that fails (damping per axis).
  const GateDevice damped = stage({{0.05, 5.0}, {0.4, 0.0}});
  const auto heavy =
      gate_scene("axis-springs", {{"stiffness", 1e5}, {"mass", 0.5}, {"damping", 20.0}}, damped, false);
  if (std::holds_alternative<GateRefusal>(heavy)) {
    const auto& message = std::get<GateRefusal>(heavy).message;
    const bool x_fails = std::holds_alternative<GateRefusal>(
        gate_scene("spring-mass", {{"stiffness", 1e5}, {"mass", 0.5}, {"damping", 20.0}},
                   rigid_device(0.05, 5.0, period, 0, world::Motion::linear), false));
    EXPECT_NE(message.find(x_fails ? "on axis x (m = 0.05 kg, b = 5 N s/m" : "on axis y (m = 0.4 kg"),
              std::string::npos)
        << message;
  }
}

TEST(TaskGate, AxisSpringsWithEachAxisItsOwnStiffnessIsJudgedWithThatAxisK) {
  // The light axis y carries a soft spring, the heavy x a stiff one: the
  // gate judges each with its own k, and refuses naming the axis that fails.
  const GateDevice device = stage({{0.3, 0.0}, {0.05, 0.0}});
  const world::ParameterSet base{{"stiffness", 100.0}, {"mass", 0.5}, {"damping", 30.0}};
  const auto limit_on = [&](double m) {
    const auto one = gate_scene("spring-mass", {{"stiffness", 1e7}, {"mass", 0.5}, {"damping", 30.0}},
                                rigid_device(m, 0.0, period, 0, world::Motion::linear), false);
    EXPECT_TRUE(std::holds_alternative<GateRefusal>(one));
    return *std::get<GateRefusal>(one).stiffness_limit;
  };
  const double kx = limit_on(0.3), ky = limit_on(0.05);
  ASSERT_GT(kx, ky) << "the heavier axis holds a stiffer spring";
  const auto with = [&](double x, double y) {
    world::ParameterSet p = base;
    p["axis_stiffness"] = std::to_string(x) + "," + std::to_string(y);
    return gate_scene("axis-springs", p, device, false);
  };
  // Each axis below its own limit: accepted, although x's k is above y's limit.
  EXPECT_TRUE(std::holds_alternative<GateAccepted>(with(0.9 * kx, 0.9 * ky)));
  ASSERT_GT(0.9 * kx, ky);
  const auto x_fails = with(1.1 * kx, 0.5 * ky);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(x_fails));
  EXPECT_TRUE(std::get<GateRefusal>(x_fails).message.starts_with("axis-springs on axis x (m = 0.3 kg"))
      << std::get<GateRefusal>(x_fails).message;
  EXPECT_NEAR(*std::get<GateRefusal>(x_fails).stiffness_limit / kx, 1.0, 1e-6)
      << "to the limit search's tolerance";
  const auto y_fails = with(0.5 * kx, 1.1 * ky);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(y_fails));
  EXPECT_TRUE(std::get<GateRefusal>(y_fails).message.starts_with("axis-springs on axis y (m = 0.05 kg"))
      << std::get<GateRefusal>(y_fails).message;
}

TEST(TaskGate, AxisSpringsWithEachAxisItsOwnMassAndDampingIsJudgedWithThemOnItsAxis) {
  // axis_mass and axis_damping: each axis is judged as spring-mass with its
  // own virtual m and b on that axis of the device, and with nothing else.
  const GateDevice device = stage({{0.3, 0.0}, {0.05, 0.0}});
  const auto accepted = [](const auto& outcome) { return std::holds_alternative<GateAccepted>(outcome); };
  const auto alone = [&](double device_mass, double k, double m, double b) {
    return gate_scene("spring-mass", {{"stiffness", k}, {"mass", m}, {"damping", b}},
                      rigid_device(device_mass, 0.0, period, 0, world::Motion::linear), false);
  };
  int differs_from_common = 0;
  for (const double k : {1e3, 3e3, 1e4, 3e4, 1e5, 3e5, 1e6}) {
    const world::ParameterSet own{
        {"stiffness", k}, {"mass", 0.5}, {"damping", 30.0}, {"axis_mass", "0.2,2"}, {"axis_damping", "40,5"}};
    const bool every_axis = accepted(alone(0.3, k, 0.2, 40.0)) && accepted(alone(0.05, k, 2.0, 5.0));
    const auto outcome = gate_scene("axis-springs", own, device, false);
    EXPECT_EQ(accepted(outcome), every_axis) << "K = " << k;
    const bool common = accepted(alone(0.3, k, 0.5, 30.0)) && accepted(alone(0.05, k, 0.5, 30.0));
    if (common != every_axis) ++differs_from_common;
    // x (b = 40) holds where y (b = 5) does not: y is named, with its own limit.
    if (accepted(alone(0.3, k, 0.2, 40.0)) && !accepted(alone(0.05, k, 2.0, 5.0))) {
      ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
      const auto& refusal = std::get<GateRefusal>(outcome);
      EXPECT_TRUE(refusal.message.starts_with("axis-springs on axis y (m = 0.05 kg")) << refusal.message;
      const auto y_alone = alone(0.05, k, 2.0, 5.0);
      ASSERT_TRUE(refusal.stiffness_limit && std::get<GateRefusal>(y_alone).stiffness_limit);
      EXPECT_EQ(*refusal.stiffness_limit, *std::get<GateRefusal>(y_alone).stiffness_limit);
    }
  }
  EXPECT_GT(differs_from_common, 0) << "the own m and b change some verdict: the test can tell them apart";
}

TEST(TaskGate, AxisSpringsOnAPantographCannotBeAssessedSayingWhy) {
  const GateDevice device = pantograph({{5e-4, 0.0}, {5e-4, 0.0}}, TaskBox{-0.02, 0.06, 0.07, 0.12});
  const auto outcome = gate_scene("axis-springs", {}, device, false);
  ASSERT_TRUE(std::holds_alternative<GateRefusal>(outcome));
  EXPECT_FALSE(std::get<GateRefusal>(outcome).assessed);
  EXPECT_NE(std::get<GateRefusal>(outcome).message.find("needs a Cartesian stage"), std::string::npos);
}

}  // namespace task_gate_test
