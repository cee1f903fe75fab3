// The scene registry (world/scene_registry.hpp): every scene describes
// itself (parameters, what it needs from the device, how the gate judges
// it, its factory), and the one list makes both the catalog and AnyScene.

#include <string>
#include <type_traits>
#include <variant>

#include <gtest/gtest.h>

#include "world/scene_catalog.hpp"

namespace hapticd::world::scene_registry_test {
namespace {

// The RT variant is what it was when it was written out by hand: the same
// alternatives in the same order, FreeScene first (a default AnyScene is free),
// each scene with the passivity option after its plain variants.
template <class S>
using Pc = PassivityControlledScene<S>;
using HandWritten = std::variant<
    FreeScene, SpringScene<SpringDamping::none>, SpringScene<SpringDamping::absolute>,
    SpringScene<SpringDamping::relative>, Pc<SpringScene<SpringDamping::none>>,
    Pc<SpringScene<SpringDamping::absolute>>, Pc<SpringScene<SpringDamping::relative>>,
    WallScene<WallDamping::none, WallDelay::none>, WallScene<WallDamping::none, WallDelay::samples>,
    WallScene<WallDamping::backward_difference, WallDelay::none>,
    WallScene<WallDamping::backward_difference, WallDelay::samples>,
    Pc<WallScene<WallDamping::none, WallDelay::none>>, Pc<WallScene<WallDamping::none, WallDelay::samples>>,
    Pc<WallScene<WallDamping::backward_difference, WallDelay::none>>,
    Pc<WallScene<WallDamping::backward_difference, WallDelay::samples>>, RelayScene<RelayHysteresis::none>,
    RelayScene<RelayHysteresis::band>, RelayScene<RelayHysteresis::none, RelayDelay::samples>,
    RelayScene<RelayHysteresis::band, RelayDelay::samples>, ChirpScene>;
static_assert(std::is_same_v<AnyScene, HandWritten>);
// The damped wall with the passivity option: its three, passivity_energy and passivity_damping.
static_assert(max_scene_channels == 5);

TEST(SceneRegistry, EveryScenesDescriptionIsComplete) {
  for (const auto& scene : scene_catalog()) {
    EXPECT_FALSE(scene.reference.empty()) << scene.name;
    EXPECT_FALSE(scene.summary.empty()) << scene.name;
    EXPECT_NE(scene.build, nullptr) << scene.name;
    for (const auto& p : scene.parameters) {
      EXPECT_TRUE(p.default_value.has_value()) << scene.name << "." << p.name;
      EXPECT_FALSE(p.help.empty()) << scene.name << "." << p.name;
    }
  }
}

// The gate checks a scene by its rule; the factory must give a rule other
// than none the linear model it checks (and none no model to ignore); a
// task-space wall (on two axes) what the gate judges along its directions.
TEST(SceneRegistry, ALinearRuleComesWithALinearModel) {
  for (const auto& scene : scene_catalog()) {
    const int axes = scene.space == SceneSpace::task ? 2 : 1;
    for (const Motion motion : {Motion::linear, Motion::rotary}) {
      PlanResult result = plan_scene(scene.name, {}, 1e-3, motion, axes);
      ASSERT_TRUE(std::holds_alternative<ScenePlan>(result)) << scene.name;
      const auto& plan = std::get<ScenePlan>(result);
      EXPECT_EQ(plan.description, &scene);
      const bool task_wall = scene.stability == StabilityRule::task_wall;
      const bool per_axis = scene.stability == StabilityRule::per_axis;
      EXPECT_EQ(plan.linear.has_value(), scene.stability != StabilityRule::none && !task_wall && !per_axis)
          << scene.name;
      EXPECT_EQ(plan.task_wall.has_value(), task_wall) << scene.name;
      EXPECT_EQ(plan.per_axis.has_value(), per_axis) << scene.name;
    }
  }
}

TEST(SceneRegistry, ScenesSayWhatTheyNeedFromTheDeviceAndHowTheyAreJudged) {
  EXPECT_EQ(find_scene("spring-wheel")->fixed_motion, Motion::rotary);
  EXPECT_EQ(find_scene("spring-mass")->fixed_motion, Motion::linear);
  for (const char* name : {"wall", "relay", "chirp", "free"}) {
    EXPECT_FALSE(find_scene(name)->fixed_motion.has_value()) << name;
  }
  EXPECT_EQ(find_scene("wall")->stability, StabilityRule::hulin_wall);
  EXPECT_EQ(find_scene("spring-wheel")->stability, StabilityRule::linear);
  EXPECT_EQ(find_scene("spring-mass")->stability, StabilityRule::linear);
  for (const char* name : {"relay", "chirp", "free"}) {
    EXPECT_EQ(find_scene(name)->stability, StabilityRule::none) << name;
  }
  EXPECT_NE(find_scene("spring-wheel")->unstable_hint.find("damping=auto"), std::string::npos);
  EXPECT_TRUE(find_scene("wall")->unstable_hint.empty());
}

// A scene of fixed motion plans in its own units whatever the device's.
TEST(SceneRegistry, FixedMotionWinsOverTheDevices) {
  const auto wheel = std::get<ScenePlan>(plan_scene("spring-wheel", {}, 1e-3, Motion::linear));
  EXPECT_EQ(wheel.channels[0].unit, "rad");
  const auto mass = std::get<ScenePlan>(plan_scene("spring-mass", {}, 1e-3, Motion::rotary));
  EXPECT_EQ(mass.channels[0].unit, "m");
  const auto wall = std::get<ScenePlan>(plan_scene("wall", {}, 1e-3, Motion::rotary));
  EXPECT_EQ(wall.channels[0].unit, "rad");
}

TEST(SceneRegistry, ChoicesTypeAsEnumForTheProtocol) {
  EXPECT_EQ(scene_type_name(ParameterType::choice), "enum");
  EXPECT_EQ(scene_type_name(ParameterType::number), "number");
  EXPECT_EQ(scene_type_name(ParameterType::integer), "integer");
  EXPECT_EQ(scene_type_name(ParameterType::boolean), "bool");
}

}  // namespace
}  // namespace hapticd::world::scene_registry_test
