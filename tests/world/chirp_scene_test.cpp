// chirp: the excitation force of `hapticctl identify`.

#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "world/any_scene.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::world::chirp_scene_test {
namespace {

constexpr double T = 1e-3;

// A chirp keeps no memory beyond its step count and constants.
static_assert(sizeof(ChirpScene) <= 11 * sizeof(double));

std::vector<double> run(ChirpScene& chirp, int steps) {
  std::vector<double> out;
  for (int n = 0; n < steps; ++n) out.push_back(chirp.step(0.0));
  return out;
}

TEST(ChirpScene, BoundedPeriodicZeroMeanAndFadedAtBothEnds) {
  ChirpScene chirp({2.5, 1.0, 100.0, 2.0, 9.0}, T);
  EXPECT_EQ(chirp.sweep_steps(), 2000);
  EXPECT_EQ(chirp.fade_steps(), 1000);  // one cycle of f0
  chirp.reset(0.3);
  const auto f = run(chirp, 9000);
  EXPECT_EQ(f[0], 0.0);                // no force step when loaded
  EXPECT_LT(std::abs(f[8999]), 1e-4);  // nor when it ends
  double peak = 0.0, sum = 0.0;
  for (int n = 2000; n < 4000; ++n) {
    peak = std::max(peak, std::abs(f[static_cast<std::size_t>(n)]));
    sum += f[static_cast<std::size_t>(n)];
  }
  EXPECT_LE(peak, 2.5);
  EXPECT_GT(peak, 2.3);
  EXPECT_NEAR(sum, 0.0, 1e-9);      // no mean force: a free device is not pushed away
  for (int n = 0; n < 2000; ++n) {  // sweeps 2, 3 and 4 (past the fade in, before the fade out)
    ASSERT_EQ(f[static_cast<std::size_t>(n + 2000)], f[static_cast<std::size_t>(n + 4000)]) << n;
    ASSERT_EQ(f[static_cast<std::size_t>(n + 2000)], f[static_cast<std::size_t>(n + 6000)]) << n;
  }
  for (int n = 0; n < 1000; ++n) {  // inside the raised-cosine envelope at both ends
    const double envelope = 2.5 * (0.5 - 0.5 * std::cos(std::numbers::pi * n / 1000.0)) + 1e-12;
    ASSERT_LE(std::abs(f[static_cast<std::size_t>(n)]), envelope) << n;
    ASSERT_LE(std::abs(f[static_cast<std::size_t>(9000 - n - 1)]), envelope + 0.01) << n;
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
  ChirpScene chirp({1.0, 5.0, 50.0, 4.0, 12.0}, T);
  auto f = run(chirp, 8000);
  f.erase(f.begin(), f.begin() + 4000);  // the second sweep, past the fade in
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
}  // namespace hapticd::world::chirp_scene_test
