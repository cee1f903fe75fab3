// The task-space scenes in the scene registry (world/task_scenes.hpp):
// planned like any scene from validated parameters, each with the variant it
// needs, what the gate judges, refused on a device that cannot run them, and
// today's one-axis scenes refused on several axes (free is both).

#include "world/task_scenes.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <variant>
#include <vector>

#include "world/scene_catalog.hpp"

namespace task_scenes_test {

namespace {

using namespace hapticd::world;

constexpr double period = 1e-3;

ScenePlan planned(std::string_view scene, const ParameterSet& given, int axes) {
  auto outcome = plan_scene(scene, given, period, Motion::linear, axes);
  if (const auto* e = std::get_if<SceneError>(&outcome)) {
    ADD_FAILURE() << scene << ": " << e->message;
    return {};
  }
  return std::get<ScenePlan>(std::move(outcome));
}

std::string refusal(std::string_view scene, const ParameterSet& given, int axes) {
  auto outcome = plan_scene(scene, given, period, Motion::linear, axes);
  if (const auto* e = std::get_if<SceneError>(&outcome)) return e->message;
  return "accepted";
}

AxisVector vec(double a, double b) {
  AxisVector v(2);
  v << a, b;
  return v;
}

TEST(TaskScenes, APlaneWallIsPlannedWithTheVariantItNeedsAndItsNormalJudged) {
  const ScenePlan plan = planned("plane-wall", {{"normal", "1,1"}, {"stiffness", 2000.0}}, 2);
  using Damped = TaskWallScene<PlaneWall<WallDamping::backward_difference, WallDelay::samples>>;
  ASSERT_TRUE(std::holds_alternative<Damped>(plan.task_object)) << "defaults: B = 46 N s/m, d = 1";
  ASSERT_TRUE(plan.task_wall.has_value());
  ASSERT_EQ(plan.task_wall->directions.size(), 1U);
  EXPECT_NEAR((plan.task_wall->directions[0] - vec(1, 1) / std::sqrt(2.0)).norm(), 0.0, 1e-15);
  EXPECT_EQ(plan.task_wall->labels[0], "the normal (0.7071, 0.7071)");
  EXPECT_EQ(plan.task_wall->law.stiffness, 2000.0);
  EXPECT_EQ(plan.task_wall->law.delay_samples, 1);
  EXPECT_FALSE(plan.linear.has_value()) << "the gate judges it along its normal, not by a one-axis model";
  ASSERT_EQ(plan.channels.size(), 1U);
  EXPECT_EQ(plan.channels[0].name, "penetration");
  EXPECT_EQ(plan.channels[0].unit, "m");

  const ScenePlan plain = planned("plane-wall", {{"damping", 0.0}, {"delay", 0.0}}, 3);
  using Plain = TaskWallScene<PlaneWall<WallDamping::none, WallDelay::none>>;
  ASSERT_TRUE(std::holds_alternative<Plain>(plain.task_object));
  EXPECT_LT(sizeof(Plain), sizeof(Damped)) << "no estimator, no delay line";
  // The default normal is the first axis.
  AxisVector first(3);
  first << 1, 0, 0;
  EXPECT_EQ(plain.task_wall->directions[0], first);
}

TEST(TaskScenes, ThePlannedWallRendersKTimesThePenetrationAlongN) {
  ScenePlan plan =
      planned("plane-wall", {{"normal", "1,1"}, {"offset", 0.0}, {"damping", 0.0}, {"delay", 0.0}}, 2);
  const double n = 1.0 / std::sqrt(2.0);  // each component of the unit normal
  AnyTaskScene scene = plan.task_object;
  reset(scene, vec(0.01, 0.0));
  AxisVector f;
  for (int um = 100; um >= -100; --um) {
    const double x = 1e-4 * um;
    step(scene, vec(x, 0.0), f);
    const double depth = std::max(0.0, -x * n);
    EXPECT_NEAR(f(0), 9000.0 * depth * n, 1e-11) << um;
    EXPECT_NEAR(f(1), 9000.0 * depth * n, 1e-11) << um;
  }
  std::array<double, 1> penetration{};
  channels(scene, penetration);
  EXPECT_NEAR(penetration[0], 0.01 / std::sqrt(2.0), 1e-15);
}

TEST(TaskScenes, ASphereAndABoxAreJudgedInTheirOwnDirections) {
  const ScenePlan sphere = planned("sphere", {{"center", "0.1, 0"}, {"radius", 0.02}, {"side", "inside"}}, 2);
  ASSERT_TRUE(sphere.task_wall.has_value());
  EXPECT_TRUE(sphere.task_wall->directions.empty()) << "the worst direction: the gate finds it";
  AnyTaskScene ball = sphere.task_object;
  reset(ball, vec(0.1, 0.0));
  AxisVector f;
  for (int i = 0; i < 3; ++i) step(ball, vec(0.1, 0.03), f);  // 1 cm outside the inside ball
  EXPECT_NEAR(f(1), -9000.0 * 0.01, 1e-9) << "after the one-sample delay, K pen towards the center";

  const ScenePlan box = planned("box", {{"low", "-0.01,-0.02"}, {"high", "0.01,0.02"}, {"delay", 0.0}}, 2);
  ASSERT_TRUE(box.task_wall.has_value());
  EXPECT_TRUE(box.task_wall->along_axes);
  ASSERT_EQ(box.task_wall->directions.size(), 2U);
  EXPECT_EQ(box.task_wall->directions[1], vec(0, 1));
  EXPECT_EQ(box.task_wall->labels[1], "axis 2");
}

TEST(TaskScenes, BadVectorsAreRefusedNamingTheParameter) {
  EXPECT_EQ(refusal("plane-wall", {{"normal", "1,1,1"}}, 2),
            "plane-wall: normal: '1,1,1' is not accepted; 2 comma-separated finite numbers, one per axis");
  EXPECT_EQ(refusal("plane-wall", {{"normal", "0,0"}}, 2), "plane-wall: normal: a direction, not all zero");
  EXPECT_EQ(refusal("plane-wall", {{"normal", "1,nan"}}, 2),
            "plane-wall: normal: '1,nan' is not accepted; 2 comma-separated finite numbers, one per axis");
  EXPECT_EQ(refusal("sphere", {{"center", "x"}}, 2),
            "sphere: center: 'x' is not accepted; 2 comma-separated numbers from -1e+06 to 1e+06 (m), one "
            "per axis");
  EXPECT_EQ(refusal("box", {{"high", "1e308,1"}}, 2),
            "box: high: '1e308,1' is not accepted; 2 comma-separated numbers from -1e+06 to 1e+06 (m), one "
            "per axis");
  const ScenePlan huge = planned("plane-wall", {{"normal", "1e308,1e308"}}, 2);
  EXPECT_EQ(huge.task_wall->labels[0], "the normal (0.7071, 0.7071)") << "a long normal is still a direction";
  EXPECT_EQ(planned("plane-wall", {{"normal", "1e-320,0"}}, 2).task_wall->labels[0], "the normal (1, 0)")
      << "nor is a short one nothing";
  EXPECT_EQ(refusal("box", {{"low", "0,0"}, {"high", "0.01,0"}}, 2),
            "box: low, high: low < high on every axis; axis 2 has low 0 m, high 0 m");
  EXPECT_EQ(refusal("plane-wall", {{"normal", 1.0}}, 2),
            "normal: 1 is not accepted; comma-separated numbers, one per axis");
  EXPECT_EQ(refusal("sphere", {{"radius", 0.0}}, 2),
            "radius: 0 is not accepted; a finite number > 0 and <= 1e+06 (m)");
}

TEST(TaskScenes, EachDeviceTakesOnlyTheScenesThatMeanSomethingOnIt) {
  EXPECT_EQ(refusal("plane-wall", {}, 1),
            "plane-wall is a task-space scene for a device with several axes; this device has one axis; "
            "accepted: spring-wheel, spring-mass, wall, relay, chirp, free");
  EXPECT_EQ(refusal("wall", {}, 2),
            "wall renders on one axis; this device has 2 axes; accepted: free, plane-wall, sphere, box, "
            "axis-springs");
  EXPECT_EQ(refusal("spring-wheel", {}, 3).substr(0, 34), "spring-wheel renders on one axis; ");
  const ScenePlan free_on_two = planned("free", {}, 2);
  ASSERT_TRUE(std::holds_alternative<TaskFreeScene>(free_on_two.task_object));
  AnyTaskScene scene = free_on_two.task_object;
  AxisVector f = vec(1, 1);
  step(scene, vec(0.3, -0.2), f);
  EXPECT_EQ(f, vec(0, 0)) << "free: zero force on every axis";
  EXPECT_EQ(refusal("free", {}, 1), "accepted");
  EXPECT_EQ(refusal("free", {}, 7), "axes: 7 is not accepted; 1 to 6");
  EXPECT_EQ(scene_names_for(2), "free, plane-wall, sphere, box, axis-springs");
}

// ---- axis-springs: today's spring-mass on each axis ----

TEST(TaskScenes, AxisSpringsIsSpringMassOnEachAxisSampleBySample) {
  for (const char* damping : {"0", "3", "auto"}) {
    for (const char* reference : {"relative", "absolute"}) {
      SCOPED_TRACE(std::string(damping) + " " + reference);
      const ParameterSet given{{"stiffness", 400.0},
                               {"mass", 0.2},
                               {"damping", std::string(damping)},
                               {"damping_reference", std::string(reference)}};
      const ScenePlan plan = planned("axis-springs", given, 3);
      ASSERT_TRUE(plan.per_axis.has_value());
      EXPECT_EQ(plan.per_axis->scene, "spring-mass");
      EXPECT_TRUE(plan.channels.empty());
      // The one-axis scene the gate judges runs on each axis, unchanged.
      AnyTaskScene scene = plan.task_object;
      std::vector<AnyScene> one;
      for (int i = 0; i < 3; ++i) {
        auto outcome = plan_scene("spring-mass", plan.per_axis->parameters, period, Motion::linear, 1);
        ASSERT_TRUE(std::holds_alternative<ScenePlan>(outcome));
        one.push_back(std::get<ScenePlan>(outcome).scene_object);
      }
      AxisVector x(3);
      x << 0.01, -0.02, 0.005;
      reset(scene, x);
      for (int i = 0; i < 3; ++i) reset(one[static_cast<std::size_t>(i)], x(i));
      AxisVector f;
      for (int n = 0; n < 500; ++n) {
        x << 0.01 + 0.02 * std::sin(0.01 * n), -0.02 + 0.01 * std::cos(0.03 * n), 0.005;
        step(scene, x, f);
        ASSERT_EQ(f.size(), 3);
        for (int i = 0; i < 3; ++i)
          ASSERT_EQ(f(i), step(one[static_cast<std::size_t>(i)], x(i))) << "axis " << i << ", step " << n;
      }
    }
  }
}

TEST(TaskScenes, AxisSpringsCarriesOnlyWhatItUsesAndRunsOnlyOnAStage) {
  EXPECT_TRUE(std::holds_alternative<AxisSpringsScene<SpringDamping::none>>(
      planned("axis-springs", {{"damping", 0.0}}, 2).task_object));
  EXPECT_TRUE(std::holds_alternative<AxisSpringsScene<SpringDamping::absolute>>(
      planned("axis-springs", {{"damping", 1.0}, {"damping_reference", "absolute"}}, 2).task_object));
  EXPECT_TRUE(std::holds_alternative<AxisSpringsScene<SpringDamping::relative>>(
      planned("axis-springs", {{"damping", 1.0}}, 2).task_object));
  EXPECT_EQ(refusal("axis-springs", {{"passivity", "observer"}}, 2).substr(0, 45),
            "unknown parameter 'passivity' for scene axis-");
  EXPECT_EQ(refusal("axis-springs", {}, 1).substr(0, 60),
            "axis-springs is a task-space scene for a device with several");
  const ScenePlan resolved = planned("axis-springs", {{"stiffness", 500.0}, {"damping", "auto"}}, 2);
  EXPECT_EQ(std::get<double>(resolved.per_axis->parameters.at("damping")), 0.5) << "T k, as on one axis";
  EXPECT_TRUE(resolved.per_axis->axes.empty()) << "one set for every axis";
  EXPECT_EQ(resolved.per_axis->parameters.count("axis_stiffness"), 0U) << "spring-mass has one k";
}

TEST(TaskScenes, AxisSpringsTakesEachAxisItsOwnStiffness) {
  for (const char* damping : {"0", "3", "auto"}) {
    SCOPED_TRACE(damping);
    const ParameterSet given{{"stiffness", 400.0},
                             {"axis_stiffness", "400,100,0"},
                             {"mass", 0.2},
                             {"damping", std::string(damping)}};
    const ScenePlan plan = planned("axis-springs", given, 3);
    ASSERT_EQ(plan.per_axis->axes.size(), 3U);
    AnyTaskScene scene = plan.task_object;
    std::vector<AnyScene> one;
    for (int i = 0; i < 3; ++i) {
      const ParameterSet& own = plan.per_axis->on_axis(static_cast<std::size_t>(i));
      const std::array<double, 3> k{400.0, 100.0, 0.0};
      EXPECT_EQ(std::get<double>(own.at("stiffness")), k[static_cast<std::size_t>(i)]);
      if (std::string(damping) == "auto") {
        EXPECT_DOUBLE_EQ(std::get<double>(own.at("damping")), period * k[static_cast<std::size_t>(i)])
            << "T k_i on each axis";
      }
      auto outcome = plan_scene("spring-mass", own, period, Motion::linear, 1);
      ASSERT_TRUE(std::holds_alternative<ScenePlan>(outcome));
      one.push_back(std::get<ScenePlan>(outcome).scene_object);
    }
    AxisVector x(3);
    x << 0.01, -0.02, 0.005;
    reset(scene, x);
    for (int i = 0; i < 3; ++i) reset(one[static_cast<std::size_t>(i)], x(i));
    AxisVector f;
    for (int n = 0; n < 500; ++n) {
      x << 0.01 + 0.02 * std::sin(0.01 * n), -0.02 + 0.01 * std::cos(0.03 * n), 0.005 + 0.001 * n;
      step(scene, x, f);
      for (int i = 0; i < 3; ++i)
        ASSERT_EQ(f(i), step(one[static_cast<std::size_t>(i)], x(i))) << "axis " << i << ", step " << n;
      if (std::string(damping) != "3") {
        ASSERT_EQ(f(2), 0.0) << "k = 0 and b = T k = 0: nothing on z";
      }
    }
  }
  EXPECT_NE(refusal("axis-springs", {{"axis_stiffness", "400,100"}}, 3)
                .find("axis_stiffness: '400,100' is not "
                      "accepted; 3 comma-separated"),
            std::string::npos);
  EXPECT_NE(
      refusal("axis-springs", {{"axis_stiffness", "400,-1"}}, 2).find("axis_stiffness: each axis' k from 0"),
      std::string::npos);
}

TEST(TaskScenes, AxisSpringsTakesEachAxisItsOwnMassAndDamping) {
  const ParameterSet given{{"stiffness", 400.0},
                           {"axis_mass", "0.2,1.5"},
                           {"axis_damping", "2,0.5"},
                           {"damping", "auto"},
                           {"axis_stiffness", "400,900"}};
  const ScenePlan plan = planned("axis-springs", given, 2);
  ASSERT_EQ(plan.per_axis->axes.size(), 2U);
  const std::array<double, 2> k{400.0, 900.0}, m{0.2, 1.5}, b{2.0, 0.5};
  AnyTaskScene scene = plan.task_object;
  std::vector<AnyScene> one;
  for (std::size_t i = 0; i < 2; ++i) {
    const ParameterSet& own = plan.per_axis->on_axis(i);
    EXPECT_EQ(std::get<double>(own.at("stiffness")), k[i]);
    EXPECT_EQ(std::get<double>(own.at("mass")), m[i]);
    EXPECT_EQ(std::get<double>(own.at("damping")), b[i]) << "axis_damping over damping = auto";
    EXPECT_EQ(own.count("axis_mass") + own.count("axis_damping"), 0U) << "spring-mass has one of each";
    auto outcome = plan_scene("spring-mass", own, period, Motion::linear, 1);
    ASSERT_TRUE(std::holds_alternative<ScenePlan>(outcome));
    one.push_back(std::get<ScenePlan>(outcome).scene_object);
  }
  AxisVector x(2);
  x << 0.01, -0.02;
  reset(scene, x);
  for (std::size_t i = 0; i < 2; ++i) reset(one[i], x(static_cast<Eigen::Index>(i)));
  AxisVector f;
  for (int n = 0; n < 500; ++n) {
    x << 0.01 + 0.02 * std::sin(0.01 * n), -0.02 + 0.01 * std::cos(0.03 * n);
    step(scene, x, f);
    for (std::size_t i = 0; i < 2; ++i)
      ASSERT_EQ(f(static_cast<Eigen::Index>(i)), step(one[i], x(static_cast<Eigen::Index>(i))))
          << "axis " << i << ", step " << n;
  }
  EXPECT_NE(
      refusal("axis-springs", {{"axis_mass", "0.2,0"}}, 2).find("axis_mass: each axis' mass from 1e-09"),
      std::string::npos);
  EXPECT_NE(refusal("axis-springs", {{"axis_damping", "-1,2"}}, 2).find("axis_damping: each axis' b from 0"),
            std::string::npos);
  EXPECT_NE(refusal("axis-springs", {{"axis_mass", "1,2,3"}}, 2).find("axis_mass: '1,2,3' is not accepted"),
            std::string::npos);
}

}  // namespace

}  // namespace task_scenes_test
