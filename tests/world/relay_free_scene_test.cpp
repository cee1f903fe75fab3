// relay (Diaz & Gil V) and free.

#include <array>
#include <vector>

#include <gtest/gtest.h>

#include "world/any_scene.hpp"

namespace hapticd::world::relay_free_scene_test {
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

using DelayedPlain = RelayScene<RelayHysteresis::none, RelayDelay::samples>;
using DelayedBand = RelayScene<RelayHysteresis::band, RelayDelay::samples>;

// Only a delayed relay carries the delay line.
static_assert(sizeof(DelayedPlain) >= sizeof(Plain) + max_relay_delay_samples * sizeof(double));
static_assert(sizeof(Plain) < 8 * sizeof(double));

TEST(RelayScene, DelayLineAppliesTheDecisionDSamplesLater) {
  // Diaz & Gil eq. (25): C(z) = K z^-d. The decision at n is applied at n + d;
  // the first d outputs after reset are 0.
  RelayParameters p{2.0, 0.0, 0.0};
  p.delay_samples = 3;
  DelayedPlain relay(p);
  EXPECT_EQ(relay.delay_samples(), 3u);
  relay.reset(0.5);
  const double positions[] = {0.5, -0.5, 0.5, 0.5, -0.5, -0.5, 0.5};
  std::vector<double> out;
  for (const double y : positions) out.push_back(relay.step(y));
  EXPECT_EQ(out, (std::vector<double>{0.0, 0.0, 0.0, -2.0, 2.0, -2.0, -2.0}));
}

TEST(RelayScene, DelayedBandKeepsItsMemoryBehindTheLine) {
  RelayParameters p{1.0, 0.1, 0.0};
  p.delay_samples = 1;
  DelayedBand relay(p);
  relay.reset(0.0);
  EXPECT_EQ(relay.step(0.2), 0.0);    // decision -1, still in the line
  EXPECT_EQ(relay.step(0.05), -1.0);  // decision keeps -1
  EXPECT_EQ(relay.step(-0.2), -1.0);  // decision +1
  EXPECT_EQ(relay.step(0.0), 1.0);
}

TEST(RelayScene, StopsByItselfAfterItsDurationAndAResetDoesNotRestartIt) {
  RelayParameters p{1.0, 0.0, 0.0};
  p.duration_steps = 4;
  Plain relay(p);
  relay.reset(1.0);
  for (int n = 0; n < 4; ++n) EXPECT_EQ(relay.step(n % 2 == 0 ? 1.0 : -1.0), n % 2 == 0 ? -1.0 : 1.0) << n;
  EXPECT_TRUE(relay.finished());
  for (int n = 0; n < 10; ++n) EXPECT_EQ(relay.step(1.0), 0.0);
  relay.reset(1.0);  // a cleared fault resets the scene: the experiment stays over
  EXPECT_EQ(relay.step(1.0), 0.0);
  std::array<double, 1> ch{};
  relay.channels(ch);
  EXPECT_EQ(ch[0], 1.0);  // the error is still reported
}

TEST(RelayScene, WithoutDurationItNeverStops) {
  Plain relay(RelayParameters{1.0, 0.0, 0.0});
  relay.reset(1.0);
  for (int n = 0; n < 100000; ++n) ASSERT_EQ(relay.step(1.0), -1.0);
  EXPECT_FALSE(relay.finished());
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
}  // namespace hapticd::world::relay_free_scene_test
