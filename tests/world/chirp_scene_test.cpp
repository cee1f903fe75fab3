// chirp: the excitation force of `hapticctl identify`.

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "world/any_scene.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::world {
namespace {

constexpr double T = 1e-3;

// A chirp keeps no memory beyond its step count and constants.
static_assert(sizeof(ChirpScene) <= 8 * sizeof(double));

std::vector<double> run(ChirpScene& chirp, int steps) {
  std::vector<double> out;
  for (int n = 0; n < steps; ++n) out.push_back(chirp.step(0.0));
  return out;
}

TEST(ChirpScene, BoundedPeriodicAndStartsAtZero) {
  ChirpScene chirp({2.5, 1.0, 100.0, 2.0, 6.0}, T);
  EXPECT_EQ(chirp.sweep_steps(), 2000);
  chirp.reset(0.3);
  const auto f = run(chirp, 6000);
  EXPECT_EQ(f[0], 0.0);  // sin(0): no force step when loaded
  double peak = 0.0;
  for (const double v : f) peak = std::max(peak, std::abs(v));
  EXPECT_LE(peak, 2.5);
  EXPECT_GT(peak, 2.49);
  for (int n = 0; n < 2000; ++n) {
    ASSERT_EQ(f[static_cast<std::size_t>(n)], f[static_cast<std::size_t>(n + 2000)]) << n;
    ASSERT_EQ(f[static_cast<std::size_t>(n)], f[static_cast<std::size_t>(n + 4000)]) << n;
  }
}

TEST(ChirpScene, InstantaneousFrequencySweepsExponentially) {
  ChirpScene chirp({1.0, 2.0, 200.0, 1.0, 1.0}, T);
  std::array<double, 1> ch{};
  chirp.step(0.0);
  chirp.channels(ch);
  EXPECT_DOUBLE_EQ(ch[0], 2.0);
  for (int n = 1; n <= 500; ++n) chirp.step(0.0);  // sample 500: half way, sqrt(f0 f1)
  chirp.channels(ch);
  EXPECT_NEAR(ch[0], 20.0, 1e-9);
}

TEST(ChirpScene, EnergyLiesInTheSweptBand) {
  // One period of the excitation: the DFT at the harmonics of 1/Ts inside
  // [f0, f1] carries nearly all of the energy.
  ChirpScene chirp({1.0, 5.0, 50.0, 4.0, 4.0}, T);
  const auto f = run(chirp, 4000);
  double inside = 0.0, total = 0.0;
  for (int k = 1; k < 2000; ++k) {
    std::complex<double> acc = 0.0;
    for (int n = 0; n < 4000; ++n) {
      acc += f[static_cast<std::size_t>(n)] * std::polar(1.0, -2.0 * std::numbers::pi * k * n / 4000.0);
    }
    const double hz = k / 4.0;
    total += std::norm(acc);
    if (hz >= 4.0 && hz <= 60.0) inside += std::norm(acc);
  }
  EXPECT_GT(inside / total, 0.99);
}

TEST(ChirpScene, StopsByItselfAndAResetDoesNotRestartIt) {
  ChirpScene chirp({1.0, 1.0, 10.0, 0.5, 0.01}, T);
  const auto f = run(chirp, 10);
  EXPECT_NE(f[1], 0.0);
  EXPECT_TRUE(chirp.finished());
  chirp.reset(0.0);
  for (int n = 0; n < 100; ++n) EXPECT_EQ(chirp.step(0.0), 0.0);
}

TEST(ChirpScene, RefusesWhatIsNotASweepAtThisPeriod) {
  EXPECT_THROW(ChirpScene({1.0, 10.0, 5.0, 1.0, 1.0}, T), std::invalid_argument);    // f1 < f0
  EXPECT_THROW(ChirpScene({1.0, 10.0, 600.0, 1.0, 1.0}, T), std::invalid_argument);  // above Nyquist
  EXPECT_THROW(ChirpScene({1.0, 1.0, 10.0, 1e-3, 1.0}, T), std::invalid_argument);   // one sample per sweep
  EXPECT_THROW(ChirpScene({0.0, 1.0, 10.0, 1.0, 1.0}, T), std::invalid_argument);
}

TEST(ChirpScene, PlannedFromTheCatalogAndRefusedThere) {
  const auto plan = plan_scene("chirp", {{"amplitude", 3.0}, {"end_frequency", "200"}}, T);
  ASSERT_TRUE(std::holds_alternative<ScenePlan>(plan));
  const auto& p = std::get<ScenePlan>(plan);
  EXPECT_TRUE(std::holds_alternative<ChirpScene>(p.scene_object));
  EXPECT_FALSE(p.linear.has_value());
  ASSERT_EQ(p.channels.size(), 1u);
  EXPECT_EQ(p.channels[0].name, "frequency");
  const auto error = std::get<SceneError>(plan_scene("chirp", {{"end_frequency", 900.0}}, T));
  EXPECT_NE(error.message.find("Nyquist"), std::string::npos) << error.message;
  const auto zero = std::get<SceneError>(plan_scene("chirp", {{"amplitude", 0.0}}, T));
  EXPECT_EQ(zero.parameter, "amplitude");
}

TEST(RelayCatalog, DelayAndDurationPickTheVariant) {
  auto relay = [](ParameterSet p) { return std::get<ScenePlan>(plan_scene("relay", p, T)).scene_object; };
  EXPECT_TRUE((std::holds_alternative<RelayScene<RelayHysteresis::none>>(relay({}))));
  EXPECT_TRUE((std::holds_alternative<RelayScene<RelayHysteresis::none, RelayDelay::samples>>(
      relay({{"delay", 4.0}}))));
  EXPECT_TRUE((std::holds_alternative<RelayScene<RelayHysteresis::band, RelayDelay::samples>>(
      relay({{"delay", "2"}, {"hysteresis", 1e-4}}))));
  auto scene = std::get<RelayScene<RelayHysteresis::none>>(relay({{"duration", 0.005}}));
  scene.reset(1.0);
  for (int n = 0; n < 5; ++n) EXPECT_NE(scene.step(1.0), 0.0);
  EXPECT_EQ(scene.step(1.0), 0.0);
  EXPECT_EQ(std::get<SceneError>(plan_scene("relay", {{"delay", 129.0}}, T)).parameter, "delay");
  EXPECT_EQ(std::get<SceneError>(plan_scene("relay", {{"delay", 1.5}}, T)).parameter, "delay");
}

}  // namespace
}  // namespace hapticd::world
