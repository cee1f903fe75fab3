// relay (Diaz & Gil V) and free.

#include <array>

#include <gtest/gtest.h>

#include "world/any_scene.hpp"

namespace hapticd::world {
namespace {

using Plain = RelayScene<RelayHysteresis::none>;
using Band = RelayScene<RelayHysteresis::band>;

// Without hysteresis the relay carries no memory of its last output (nor the band).
static_assert(sizeof(Plain) + 2 * sizeof(double) == sizeof(Band));
static_assert(FreeScene::channel_count == 0);
static_assert(std::is_empty_v<FreeScene>);

TEST(RelayScene, SignWithoutHysteresis) {
  Plain relay(RelayParameters{2.0, 0.0, 0.1});
  relay.reset(0.1);
  EXPECT_EQ(relay.step(0.1), 0.0);  // at the reference
  EXPECT_EQ(relay.step(0.1001), -2.0);
  EXPECT_EQ(relay.step(0.0999), 2.0);
  EXPECT_EQ(relay.step(5.0), -2.0);
  std::array<double, 1> ch{};
  relay.channels(ch);
  EXPECT_DOUBLE_EQ(ch[0], 4.9);
}

TEST(RelayScene, HysteresisKeepsTheLastOutputInsideTheBand) {
  Band relay(RelayParameters{1.5, 0.01, 0.0});
  relay.reset(0.0);
  EXPECT_EQ(relay.step(0.005), 0.0);  // inside the band after reset: nothing yet
  EXPECT_EQ(relay.step(0.011), -1.5);
  EXPECT_EQ(relay.step(0.0), -1.5);     // keeps
  EXPECT_EQ(relay.step(-0.009), -1.5);  // keeps
  EXPECT_EQ(relay.step(-0.0101), 1.5);
  EXPECT_EQ(relay.step(0.0099), 1.5);
  EXPECT_EQ(relay.step(0.0101), -1.5);
  relay.reset(0.0);
  EXPECT_EQ(relay.step(0.0), 0.0);
}

TEST(RelayScene, RelayOscillatesAgainstARigidMass) {
  // A relay closing the loop around a free mass must switch back and forth.
  Plain relay(RelayParameters{1.0, 0.0, 0.0});
  relay.reset(0.01);
  double x = 0.01;
  double v = 0.0;
  const double t = 1e-3;
  const double m = 1.0;
  int switches = 0;
  double last = 0.0;
  for (int n = 0; n < 5000; ++n) {
    const double f = relay.step(x);
    if (last != 0.0 && f != last) ++switches;
    last = f;
    x += v * t + 0.5 * f / m * t * t;
    v += f / m * t;
  }
  EXPECT_GT(switches, 4);
}

TEST(FreeScene, AlwaysZero) {
  FreeScene free;
  free.reset(3.0);
  for (const double y : {-1.0, 0.0, 1e9}) EXPECT_EQ(free.step(y), 0.0);
}

TEST(AnyScene, DispatchesToTheHeldScene) {
  AnyScene scene = Plain(RelayParameters{3.0, 0.0, 0.0});
  reset(scene, 0.0);
  EXPECT_EQ(channel_count(scene), 1u);
  EXPECT_EQ(step(scene, 1.0), -3.0);
  std::array<double, max_scene_channels> ch{};
  channels(scene, ch);
  EXPECT_EQ(ch[0], 1.0);
  scene = FreeScene{};
  EXPECT_EQ(channel_count(scene), 0u);
  EXPECT_EQ(step(scene, 1.0), 0.0);
}

}  // namespace
}  // namespace hapticd::world
