// The scene option passivity = "off" | "observer" | "controller" (issue 21
// part 2; world/passivity_scene.hpp): what each builds, its channels, and
// the RT rules of the wrapped scene.
#include "world/passivity_scene.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <variant>

#include <gtest/gtest.h>

#include "tests/support/alloc_counter.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::world::passivity_scene_test {
namespace {

using DampedDelayedWall = WallScene<WallDamping::backward_difference, WallDelay::samples>;

ScenePlan plan(const std::string& scene, ParameterSet p) {
  auto outcome = plan_scene(scene, p, 1e-3, Motion::linear);
  EXPECT_TRUE(std::holds_alternative<ScenePlan>(outcome)) << std::get<SceneError>(outcome).message;
  return std::move(std::get<ScenePlan>(outcome));
}

TEST(PassivityScene, OffBuildsTheSceneWithoutAnObserver) {
  const ScenePlan off = plan("wall", {});
  EXPECT_TRUE(std::holds_alternative<DampedDelayedWall>(off.scene_object));
  EXPECT_EQ(off.channels.size(), 3u);
  static_assert(sizeof(PassivityControlledScene<DampedDelayedWall>) >
                sizeof(DampedDelayedWall) + max_passivity_window * sizeof(double));
}

TEST(PassivityScene, ObserverAndControllerWrapTheSceneAndAddTwoChannelsWithUnits) {
  for (const char* mode : {"observer", "controller"}) {
    const ScenePlan p = plan("wall", {{"passivity", std::string(mode)}});
    const auto* wrapped = std::get_if<PassivityControlledScene<DampedDelayedWall>>(&p.scene_object);
    ASSERT_NE(wrapped, nullptr) << mode;
    EXPECT_EQ(wrapped->observer().config().control, std::string(mode) == "controller");
    EXPECT_EQ(wrapped->observer().config().max_damping, passivity_defaults::max_damping);
    EXPECT_EQ(wrapped->observer().config().window_periods, passivity_defaults::window_periods);
    EXPECT_EQ(wrapped->observer().config().correction, PassivityCorrection::measured);
    ASSERT_EQ(p.channels.size(), 5u);
    EXPECT_EQ(p.channels[3].name, "passivity_energy");
    EXPECT_EQ(p.channels[3].unit, "J");
    EXPECT_EQ(p.channels[4].name, "passivity_damping");
    EXPECT_EQ(p.channels[4].unit, "N s/m");
    ASSERT_TRUE(p.linear.has_value());  // the gate judges the wall's own law
  }
  const auto rotary = plan_scene("spring-wheel", {{"passivity", std::string("controller")}}, 1e-3);
  const auto& channels = std::get<ScenePlan>(rotary).channels;
  EXPECT_EQ(channels.back().unit, "N m s/rad");
}

TEST(PassivityScene, BadOptionsAreRefusedNamingWhatIsAccepted) {
  const auto mode = plan_scene("wall", {{"passivity", std::string("on")}}, 1e-3);
  ASSERT_TRUE(std::holds_alternative<SceneError>(mode));
  EXPECT_EQ(std::get<SceneError>(mode).message,
            "passivity: 'on' is not accepted; one of off, observer, controller");
  const auto window = plan_scene("wall", {{"passivity_window", 257.0}}, 1e-3);
  ASSERT_TRUE(std::holds_alternative<SceneError>(window));
  EXPECT_EQ(std::get<SceneError>(window).parameter, "passivity_window");
  const auto floor = plan_scene("spring-mass", {{"passivity_velocity_floor", 0.0}}, 1e-3);
  ASSERT_TRUE(std::holds_alternative<SceneError>(floor));
  EXPECT_EQ(std::get<SceneError>(floor).message,
            "passivity_velocity_floor: 0 is not accepted; a finite number > 0 and <= 1000 (m/s)");
}

// Observer only: the force is the scene's, and the energy is the work the
// held force did on the displacement, less what the wall holds.
TEST(PassivityScene, ObserverBooksTheHeldForcesWorkAndAddsNoForce) {
  WallParameters wp;
  wp.stiffness = 2000.0;
  wp.damping = 5.0;
  wp.delay_samples = 1;
  const double t = 1e-3;
  PassivityObserverConfig config;
  config.period_s = t;
  config.control = false;
  config.correction = PassivityCorrection::measured;
  DampedDelayedWall plain(wp, t);
  PassivityControlledScene<DampedDelayedWall> observed(DampedDelayedWall(wp, t), config);
  plain.reset(-1e-3);
  observed.reset(-1e-3);
  double y = -1e-3;
  double previous_y = y;
  double held = 0.0;
  double work = 0.0;
  for (int n = 0; n < 400; ++n) {
    y = 2e-3 * std::sin(2.0 * 3.14159265358979 * 5.0 * n * t);
    work += -held * (y - previous_y);
    previous_y = y;
    const double stored = plain.stored_energy(y);
    const double f = plain.step(y);
    EXPECT_EQ(observed.step(y), f);
    held = f;
    std::array<double, 5> ch{};
    observed.channels(ch);
    EXPECT_NEAR(ch[3], work, 1e-12 + 1e-9 * std::abs(work)) << n << " stored " << stored;
    EXPECT_EQ(ch[4], 0.0);
  }
}

TEST(PassivityScene, NonFinitePositionIsSkippedAndTheNextFinitePeriodsRecover) {
  ScenePlan p = plan("wall", {{"passivity", std::string("controller")}, {"stiffness", 5000.0}});
  AnyScene& scene = p.scene_object;
  reset(scene, -1e-3);
  step(scene, -0.5e-3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  step(scene, nan);
  const auto& wrapped = std::get<PassivityControlledScene<DampedDelayedWall>>(scene);
  EXPECT_GE(wrapped.observer().rejected(), 1u);
  for (int n = 0; n < 5; ++n) EXPECT_TRUE(std::isfinite(step(scene, -1e-3)));
  EXPECT_TRUE(std::isfinite(wrapped.observer().energy()));
}

TEST(PassivityScene, StepAllocatesNothing) {
  ScenePlan p = plan("wall", {{"passivity", std::string("controller")}, {"stiffness", 30000.0}});
  AnyScene& scene = p.scene_object;
  reset(scene, -1e-3);
  std::array<double, max_scene_channels> ch{};
  std::size_t allocations = 0;
  {
    const testing::AllocationGuard guard;
    for (int n = 0; n < 1000; ++n) {
      step(scene, 1e-4 * std::sin(0.05 * n));
      channels(scene, ch);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0u);
}

}  // namespace
}  // namespace hapticd::world::passivity_scene_test
