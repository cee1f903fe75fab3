// Scene catalog: self-description, validation messages, planning.

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "world/scene_catalog.hpp"

namespace hapticd::world::scene_catalog_test {
namespace {

std::string error_of(std::string_view name, const ParameterSet& given, double period = 1e-3,
                     Motion motion = Motion::linear) {
  const PlanResult r = plan_scene(name, given, period, motion);
  if (const auto* e = std::get_if<SceneError>(&r)) return e->message;
  return "(planned)";
}

ScenePlan plan_of(std::string_view name, const ParameterSet& given, double period = 1e-3,
                  Motion motion = Motion::linear) {
  PlanResult r = plan_scene(name, given, period, motion);
  if (auto* e = std::get_if<SceneError>(&r)) ADD_FAILURE() << e->message;
  return std::get<ScenePlan>(std::move(r));
}

TEST(SceneCatalog, ListsTheFiveScenes) {
  std::vector<std::string> names;
  for (const auto& s : scene_catalog()) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"spring-wheel", "spring-mass", "wall", "relay", "chirp", "free",
                                             "plane-wall", "sphere", "box", "axis-springs"}));
  // A one-axis device takes the first six; the last four are in task space (several axes).
  EXPECT_EQ(scene_names_for(1), "spring-wheel, spring-mass, wall, relay, chirp, free");
  EXPECT_TRUE(find_scene("free")->parameters.empty());
  const auto* wall = find_scene("wall");
  ASSERT_NE(wall, nullptr);
  EXPECT_EQ(wall->parameters.size(), 11u);  // Hulin's five and the passivity option's six
  EXPECT_EQ(find_scene("walll"), nullptr);
}

TEST(SceneCatalog, SpringWheelDefaultsFollowFreudenberg21) {
  // 800 N mm at 45 degrees, 1 Hz.
  EXPECT_NEAR(scene_defaults::wheel_stiffness, 0.8 / (std::numbers::pi / 4.0), 1e-12);
  EXPECT_NEAR(scene_defaults::wheel_stiffness, 1.0186, 1e-4);
  EXPECT_NEAR(scene_defaults::wheel_inertia, 0.0258, 1e-4);
  EXPECT_NEAR(std::sqrt(scene_defaults::wheel_stiffness / scene_defaults::wheel_inertia),
              2.0 * std::numbers::pi, 1e-12);
  const ScenePlan plan = plan_of("spring-wheel", {});
  EXPECT_EQ(std::get<double>(plan.parameters.at("stiffness")), scene_defaults::wheel_stiffness);
  EXPECT_EQ(std::get<std::string>(plan.parameters.at("integrator")), "exact");
  EXPECT_TRUE(std::holds_alternative<SpringScene<SpringDamping::none>>(plan.scene_object));
  ASSERT_EQ(plan.channels.size(), 2u);
  EXPECT_EQ(plan.channels[0].unit, "rad");
  EXPECT_EQ(plan.channels[1].unit, "rad/s");
  EXPECT_TRUE(plan.linear.has_value());
}

TEST(SceneCatalog, WallDefaultsAreHulinSection7) {
  EXPECT_NEAR(scene_defaults::wall_stiffness, 9000.0, 1e-9);
  EXPECT_NEAR(scene_defaults::wall_damping, 46.0, 1e-9);
  const ScenePlan plan = plan_of("wall", {});
  EXPECT_TRUE((std::holds_alternative<WallScene<WallDamping::backward_difference, WallDelay::samples>>(
      plan.scene_object)));
  ASSERT_TRUE(plan.linear.has_value());
  EXPECT_EQ(plan.linear->output_delay_samples, 1);
}

TEST(SceneCatalog, ChoosesTheVariantThatShowsWhatIsUsed) {
  EXPECT_TRUE((std::holds_alternative<WallScene<WallDamping::none, WallDelay::none>>(
      plan_of("wall", {{"damping", 0.0}, {"delay", 0.0}}).scene_object)));
  EXPECT_TRUE((std::holds_alternative<WallScene<WallDamping::none, WallDelay::samples>>(
      plan_of("wall", {{"damping", "0"}, {"delay", "3"}}).scene_object)));
  EXPECT_TRUE((std::holds_alternative<WallScene<WallDamping::backward_difference, WallDelay::none>>(
      plan_of("wall", {{"delay", 0.0}}).scene_object)));
  EXPECT_TRUE(std::holds_alternative<SpringScene<SpringDamping::relative>>(
      plan_of("spring-mass", {{"damping", 0.5}}).scene_object));
  EXPECT_TRUE(std::holds_alternative<SpringScene<SpringDamping::absolute>>(
      plan_of("spring-mass", {{"damping", 0.5}, {"damping_reference", "absolute"}}).scene_object));
  EXPECT_TRUE(std::holds_alternative<RelayScene<RelayHysteresis::none>>(plan_of("relay", {}).scene_object));
  EXPECT_TRUE(std::holds_alternative<RelayScene<RelayHysteresis::band>>(
      plan_of("relay", {{"hysteresis", "0.001"}}).scene_object));
  EXPECT_FALSE(plan_of("relay", {}).linear.has_value());
  EXPECT_TRUE(std::holds_alternative<FreeScene>(plan_of("free", {}).scene_object));
}

TEST(SceneCatalog, DampingAutoResolvesToTk) {
  const ScenePlan plan =
      plan_of("spring-wheel", {{"damping", "auto"}, {"integrator", "forward-euler"}}, 2e-3);
  EXPECT_NEAR(std::get<double>(plan.parameters.at("damping")), 2e-3 * scene_defaults::wheel_stiffness, 1e-15);
  EXPECT_TRUE(std::holds_alternative<SpringScene<SpringDamping::relative>>(plan.scene_object));
  EXPECT_EQ(plan.channels.size(), 3u);
  ASSERT_EQ(plan.notes.size(), 1u);
  EXPECT_NE(plan.notes[0].find("2.24"), std::string::npos);
}

TEST(SceneCatalog, AcceptsNumericTextAndIntegratorAliases) {
  const ScenePlan plan =
      plan_of("spring-mass", {{"stiffness", "12.5"}, {"mass", " 2 "}, {"integrator", "tustin"}});
  EXPECT_EQ(std::get<double>(plan.parameters.at("stiffness")), 12.5);
  EXPECT_EQ(std::get<double>(plan.parameters.at("mass")), 2.0);
  EXPECT_EQ(std::get<std::string>(plan.parameters.at("integrator")), "trapezoid");
}

TEST(SceneCatalog, ErrorMessages) {
  EXPECT_EQ(error_of("walll", {}),
            "unknown scene 'walll'; accepted: spring-wheel, spring-mass, wall, relay, chirp, free");
  EXPECT_EQ(
      error_of("wall", {{"stifness", 1.0}}),
      "unknown parameter 'stifness' for scene wall; accepted: stiffness, damping, position, side, delay, "
      "passivity, passivity_max_damping, passivity_window, passivity_velocity_floor, "
      "passivity_velocity_deadband, passivity_device_delay");
  EXPECT_EQ(error_of("free", {{"stiffness", 1.0}}),
            "unknown parameter 'stiffness' for scene free; accepted: none");
  EXPECT_EQ(error_of("spring-wheel", {{"stiffness", -3.0}}),
            "stiffness: -3 is not accepted; a finite number >= 0 and <= 1e+09 (N m/rad)");
  EXPECT_EQ(error_of("spring-mass", {{"mass", -1.0}}),
            "mass: -1 is not accepted; a finite number >= 1e-09 and <= 1e+06 (kg)");
  EXPECT_EQ(error_of("spring-mass", {{"mass", 0.0}}),
            "mass: 0 is not accepted; a finite number >= 1e-09 and <= 1e+06 (kg)");
  EXPECT_EQ(error_of("spring-mass", {{"inertia", 1.0}}),
            "unknown parameter 'inertia' for scene spring-mass; accepted: stiffness, mass, damping, "
            "damping_reference, integrator, passivity, passivity_max_damping, passivity_window, "
            "passivity_velocity_floor, passivity_velocity_deadband, passivity_device_delay");
  EXPECT_EQ(error_of("spring-mass", {{"stiffness", std::numeric_limits<double>::quiet_NaN()}}),
            "stiffness: nan is not accepted; a finite number >= 0 and <= 1e+09 (N/m)");
  EXPECT_EQ(error_of("spring-mass", {{"stiffness", "abc"}}),
            "stiffness: 'abc' is not accepted; a finite number >= 0 and <= 1e+09 (N/m)");
  EXPECT_EQ(error_of("spring-wheel", {{"damping", "automatic"}}),
            "damping: 'automatic' is not accepted; a finite number >= 0 and <= 1e+06 (N m s/rad) or auto");
  EXPECT_EQ(error_of("wall", {{"side", "middle"}}), "side: 'middle' is not accepted; one of upper, lower");
  EXPECT_EQ(error_of("wall", {{"delay", 2.5}}), "delay: 2.5 is not accepted; an integer 0..16 (samples)");
  EXPECT_EQ(error_of("wall", {{"delay", 17.0}}), "delay: 17 is not accepted; an integer 0..16 (samples)");
  EXPECT_EQ(error_of("wall", {{"stiffness", -1.0}}, 1e-3, Motion::rotary),
            "stiffness: -1 is not accepted; a finite number >= 0 and <= 1e+09 (N m/rad)");
  EXPECT_EQ(error_of("spring-wheel", {{"integrator", "leapfrog"}}),
            "integrator: 'leapfrog' is not accepted; one of forward-euler, semi-implicit-euler, trapezoid, "
            "rk4, exact");
  EXPECT_EQ(error_of("relay", {{"hysteresis", -0.1}}),
            "hysteresis: -0.1 is not accepted; a finite number >= 0 and <= 1e+06 (m)");
  EXPECT_EQ(error_of("free", {}, 0.0), "period: 0 is not accepted; a finite number > 0 (s)");
}

// Every number a scene takes has a finite range on both sides: a 1e308 N s/m
// damper overflowed b/J and B/T (the wheel then produced NaN, the wall
// chattered) and a 1e-300 kg mass overflowed k/m; both were accepted.
TEST(SceneCatalog, EveryNumberHasAFiniteRange) {
  for (const auto& scene : scene_catalog()) {
    for (const auto& p : scene.parameters) {
      if (p.type != ParameterType::number && p.type != ParameterType::integer) continue;
      ASSERT_TRUE(p.minimum.has_value()) << scene.name << "." << p.name;
      ASSERT_TRUE(p.maximum.has_value()) << scene.name << "." << p.name;
      EXPECT_TRUE(std::isfinite(*p.minimum) && std::isfinite(*p.maximum)) << scene.name << "." << p.name;
      EXPECT_LT(*p.minimum, *p.maximum) << scene.name << "." << p.name;
      // The default lies inside its own range.
      const double def = std::get<double>(*p.default_value);
      EXPECT_GE(def, *p.minimum) << scene.name << "." << p.name;
      EXPECT_LE(def, *p.maximum) << scene.name << "." << p.name;
    }
  }
}

TEST(SceneCatalog, RefusesValuesOutsideTheRangeNamingIt) {
  EXPECT_EQ(error_of("spring-wheel", {{"damping", 1e308}, {"integrator", "forward-euler"}}),
            "damping: 1e+308 is not accepted; a finite number >= 0 and <= 1e+06 (N m s/rad) or auto");
  EXPECT_EQ(error_of("wall", {{"damping", 1e308}}),
            "damping: 1e+308 is not accepted; a finite number >= 0 and <= 1e+06 (N s/m)");
  EXPECT_EQ(error_of("spring-wheel", {{"inertia", 1e-300}}),
            "inertia: 1e-300 is not accepted; a finite number >= 1e-09 and <= 1e+06 (kg m^2)");
  EXPECT_EQ(error_of("spring-mass", {{"mass", "2e6"}}),
            "mass: '2e6' is not accepted; a finite number >= 1e-09 and <= 1e+06 (kg)");
  EXPECT_EQ(error_of("wall", {{"stiffness", 1.5e9}}, 1e-3, Motion::rotary),
            "stiffness: 1.5e+09 is not accepted; a finite number >= 0 and <= 1e+09 (N m/rad)");
  EXPECT_EQ(error_of("wall", {{"position", -1e300}}),
            "position: -1e+300 is not accepted; a finite number >= -1e+06 and <= 1e+06 (m)");
  EXPECT_EQ(error_of("relay", {{"amplitude", 1e308}}, 1e-3, Motion::rotary),
            "amplitude: 1e+308 is not accepted; a finite number >= 0 and <= 1e+06 (N m)");
  EXPECT_EQ(error_of("relay", {{"reference", std::numeric_limits<double>::infinity()}}),
            "reference: inf is not accepted; a finite number >= -1e+06 and <= 1e+06 (m)");
  // The bounds themselves are accepted.
  EXPECT_EQ(error_of("spring-mass", {{"mass", parameter_range::min_mass}}), "(planned)");
  EXPECT_EQ(error_of("spring-wheel", {{"stiffness", parameter_range::max_stiffness},
                                      {"damping", parameter_range::max_damping}}),
            "(planned)");
}

TEST(SceneCatalog, PlannedSceneRunsFromReset) {
  ScenePlan plan = plan_of("spring-wheel", {{"integrator", "rk4"}});
  reset(plan.scene_object, 0.3);
  EXPECT_EQ(step(plan.scene_object, 0.3), 0.0);
  EXPECT_LT(step(plan.scene_object, 0.4), 0.0);  // device moved up: the spring pulls it back down
}

}  // namespace
}  // namespace hapticd::world::scene_catalog_test
