// End-to-end reproductions of the papers: the real hapticd on the loopback
// device, driven by its config and scripted hand, checked from its recording.
// The virtual clock makes these runs deterministic and fast; Freudenberg 4
// switches the hand through the control plane and uses the real clock.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "support.hpp"

namespace hapticd::e2e::physics_test {
namespace {

using std::numbers::pi;

// Freudenberg 2.1: 1 Hz wheel, 800 N mm at 45 degrees.
const double k_wheel = 0.8 / (pi / 4.0);               // N m/rad
const double j_wheel = k_wheel / std::pow(2 * pi, 2);  // kg m^2
const double z0 = pi / 4.0;                            // 45 degrees
const double period = 1e-3;

std::string wheel_config(const std::string& scene_extra, const std::string& hand, double duration_s) {
  return "[loop]\nclock = \"virtual\"\nduration = \"" + std::to_string(duration_s) +
         "s\"\n"
         // max_velocity: the ideal 45-degree step moves 785 rad/s (docs/config.md,
         // "Position plausibility").
         "[device]\ndriver = \"loopback\"\ntorque_limit = 1.0\nmax_velocity = 1000\n"
         "[device.loopback]\nmotion = \"rotary\"\ndamping = 0.002\nmax_force = 1.2\nhand = \"" +
         hand + "\"\n[scene]\nname = \"spring-wheel\"\n" + scene_extra;
}

Recording run_virtual(const TempDir& dir, const std::string& config) {
  Daemon daemon(dir, config, {"--record", "run.csv"});
  EXPECT_EQ(daemon.wait(std::chrono::seconds(120)), 0) << daemon.log();
  const Recording rec = read_recording(dir.path / "run.csv");
  EXPECT_NE(std::find(rec.comments.begin(), rec.comments.end(),
                      "# dropped 0 samples (ring full: 0, write failed: 0)"),
            rec.comments.end())
      << "samples were lost";
  return rec;
}

std::size_t first_index(const std::vector<double>& v, double at_least) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] >= at_least) return i;
  }
  return v.size();
}

/// Largest |x| over samples [from, to).
double peak(const std::vector<double>& x, std::size_t from, std::size_t to) {
  double m = 0;
  for (std::size_t i = from; i < to && i < x.size(); ++i) m = std::max(m, std::abs(x[i]));
  return m;
}

// Freudenberg 2 / eq. 2.4 with the exact (ZOH) integrator: the torque on the
// held wheel is -k z0 cos(w_n t) from the step on, to rounding.
TEST(Freudenberg2, ExactIntegratorMatchesCosineOverTenSeconds) {
  TempDir dir;
  const auto rec =
      run_virtual(dir, wheel_config("integrator = \"exact\"\n",
                                    "mode=hold trajectory=step amplitude=0.785398163397448 at=0.5", 11.0));
  const auto position = rec.values("position_rad");
  const auto command = rec.values("command_n_m");
  const auto applied = rec.values("applied_n_m");
  const std::size_t n0 = first_index(position, 0.7);
  ASSERT_LT(n0 + 10000, position.size());
  const double z = position[n0];               // the measured (encoder-quantized) step
  EXPECT_NEAR(z, z0, 1.001 * 2 * pi / 16384);  // the encoder truncates: within one count
  const double wn = std::sqrt(k_wheel / j_wheel);
  const double peak_torque = k_wheel * z;
  double worst = 0;
  for (std::size_t i = n0; i < n0 + 10000; ++i) {
    const double expected = -k_wheel * z * std::cos(wn * static_cast<double>(i - n0) * period);
    worst = std::max(worst, std::abs(command[i] - expected));
    ASSERT_EQ(applied[i], command[i]) << "no clipping expected below the 1 N m limit";
  }
  EXPECT_LT(worst, 1e-6 * peak_torque) << "worst deviation " << worst;
  EXPECT_NEAR(peak(command, n0, n0 + 10000), 0.8, 0.8 * 1e-3);  // 800 N mm at 45 degrees
}

// Freudenberg Fig. 8: forward Euler with b = 0 is unstable (|lambda|^2 =
// 1 + T^2 w^2, eq. 2.13): the torque grows until the torque limit. It is
// refused unless forced.
TEST(Freudenberg2, ForwardEulerGrowsUntilTheTorqueLimit) {
  TempDir dir;
  {
    const std::string refused = wheel_config("integrator = \"forward-euler\"\n",
                                             "mode=hold trajectory=step amplitude=0.785398 at=0.5", 1.0);
    Daemon daemon(dir, refused);
    EXPECT_EQ(daemon.wait(std::chrono::seconds(30)), 2);
    EXPECT_NE(daemon.log().find("unstable"), std::string::npos) << daemon.log();
    EXPECT_NE(daemon.log().find("force"), std::string::npos) << daemon.log();
  }
  TempDir dir2;
  const auto rec =
      run_virtual(dir2, wheel_config("integrator = \"forward-euler\"\nforce = true\n",
                                     "mode=hold trajectory=step amplitude=0.785398163397448 at=0.5", 20.0));
  const auto position = rec.values("position_rad");
  const auto command = rec.values("command_n_m");
  const auto applied = rec.values("applied_n_m");
  const auto flags = rec.values("flags");
  const std::size_t n0 = first_index(position, 0.7);
  const double wn = std::sqrt(k_wheel / j_wheel);
  const double growth_per_cycle = std::sqrt(1.0 + period * period * wn * wn);  // eq. 2.13, zeta = 0
  // The envelope grows at |lambda| per step: compare the peaks of seconds 1 and 6.
  const double p1 = peak(command, n0 + 1000, n0 + 2000);
  const double p6 = peak(command, n0 + 6000, n0 + 7000);
  EXPECT_NEAR(p6 / p1, std::pow(growth_per_cycle, 5000.0), 2e-3);
  // Until it meets the 1 N m limit: commanded beyond it, applied clipped to it.
  EXPECT_GT(peak(command, n0, command.size()), 1.05);
  EXPECT_DOUBLE_EQ(peak(applied, n0, applied.size()), 1.0);
  bool limited = false;
  for (double f : flags) limited |= (static_cast<unsigned>(f) & 2u) != 0;
  EXPECT_TRUE(limited) << "the torque_limited flag must be recorded";
  EXPECT_NE(rec.header.at("note").find("UNSTABLE"), std::string::npos);
}

// Freudenberg Fig. 11: b = T k (eq. 2.24) makes forward Euler a harmonic
// oscillator: the torque stays bounded at k z0.
TEST(Freudenberg2, DampingTkKeepsForwardEulerBounded) {
  TempDir dir;
  const auto rec =
      run_virtual(dir, wheel_config("integrator = \"forward-euler\"\ndamping = \"auto\"\n"
                                    "damping_reference = \"absolute\"\n",
                                    "mode=hold trajectory=step amplitude=0.785398163397448 at=0.5", 20.0));
  const auto position = rec.values("position_rad");
  const auto command = rec.values("command_n_m");
  const std::size_t n0 = first_index(position, 0.7);
  const double first = peak(command, n0, n0 + 1000);
  const double last = peak(command, command.size() - 1000, command.size());
  EXPECT_NEAR(first, 0.8, 0.8 * 5e-3);
  EXPECT_NEAR(last / first, 1.0, 5e-3) << "neither growth nor decay";
  EXPECT_LT(peak(command, n0, command.size()), 0.81);
}

/// Mean frequency (Hz) of x from its upward zero crossings over [from, to).
double crossing_frequency(const std::vector<double>& x, std::size_t from, std::size_t to) {
  std::vector<double> crossings;
  for (std::size_t i = from + 1; i < to && i < x.size(); ++i) {
    if (x[i - 1] < 0 && x[i] >= 0) {
      crossings.push_back(static_cast<double>(i - 1) + x[i - 1] / (x[i - 1] - x[i]));
    }
  }
  if (crossings.size() < 3) return 0;
  return static_cast<double>(crossings.size() - 1) / ((crossings.back() - crossings.front()) * period);
}

// Freudenberg 3: the hand lets go; device and virtual wheel drift off together
// while their distance oscillates at sqrt(k (1/J_z + 1/J_w)) (eq. 3.8).
TEST(Freudenberg3, ReleasedWheelOscillatesAtTheCoupledFrequency) {
  TempDir dir;
  const auto rec = run_virtual(
      dir, wheel_config("integrator = \"exact\"\n",
                        "mode=hold trajectory=step amplitude=0.785398163397448 at=0.5 release_at=1.3", 12.0));
  const auto position = rec.values("position_rad");
  const auto virtual_position = rec.values("virtual_position_rad");
  std::vector<double> relative(position.size());
  for (std::size_t i = 0; i < position.size(); ++i) relative[i] = position[i] - virtual_position[i];
  const double j_z = 0.01;  // the loopback wheel
  const double expected_hz = std::sqrt(k_wheel * (1.0 / j_z + 1.0 / j_wheel)) / (2 * pi);
  const double measured_hz = crossing_frequency(relative, 1500, relative.size());
  EXPECT_NEAR(measured_hz / expected_hz, 1.0, 0.01) << measured_hz << " Hz vs " << expected_hz << " Hz";
  // ... and the wheel spins off: the centre of mass keeps moving.
  EXPECT_GT(std::abs(position.back() - position[1400]), 0.5);
}

// Hulin: the wall on a 0.1 kg mass at 1 ms with d = 1, K = 9 kN/m and
// B = 0.46 m/T = 46 N s/m (the paper's "4.6" is a slip: unstable), pushed by a
// 2 N hand: stable contact, resting at the penetration F/K.
TEST(Hulin, StableContactInsideTheRegionAndRefusalOutside) {
  const auto config = [](double k, double b) {
    return "[loop]\nclock = \"virtual\"\nduration = \"3s\"\n"
           "[device]\ndriver = \"loopback\"\ntorque_limit = 20\n"
           "[device.loopback]\nmotion = \"linear\"\nmass = 0.1\nmax_force = 20\n"
           "hand = \"mode=force force=2 at=0.1\"\n"
           "[scene]\nname = \"wall\"\nstiffness = " +
           std::to_string(k) + "\ndamping = " + std::to_string(b) +
           "\ndelay = 1\nposition = 0.001\nside = \"upper\"\n";
  };
  TempDir dir;
  const auto rec = run_virtual(dir, config(9000, 46));
  const auto position = rec.values("position_m");
  const auto applied = rec.values("applied_n");
  const double rest = 0.001 + 2.0 / 9000;
  const std::size_t n = position.size();
  ASSERT_GT(n, 2500u);
  double spread = 0;
  for (std::size_t i = n - 500; i < n; ++i) spread = std::max(spread, std::abs(position[i] - rest));
  EXPECT_LT(spread, 3 * 3.14e-6) << "settled within the encoder resolution";
  // Static balance. The rest penetration F/K = 222.2 um is 70.77 encoder counts
  // (res = 3.14 um, the linear default), not a whole number, so no reading
  // balances the hand exactly: the mass rocks between the counts around
  // `rest`, and the wall law applied[i] = -K (p[i-1] - x_w) - B (p[i-1] -
  // p[i-2]) / T (d = 1) adds +-B res / T = 0.144 N at each count change.
  const double k = 9000, b = 46, mass = 0.1, hand = 2.0, wall = 0.001, res = 3.14e-6;
  for (std::size_t i = n - 500; i < n; ++i) {
    const double law = -k * (position[i - 1] - wall) - b * (position[i - 1] - position[i - 2]) / period;
    EXPECT_NEAR(applied[i], law, 1e-9) << i;
  }
  // The last sample is between count changes, on a count within one count of
  // the rest position: the spring alone balances the hand to K res = 0.028 N.
  ASSERT_EQ(position[n - 2], position[n - 3]);
  ASSERT_LT(std::abs(position[n - 2] - rest), res);
  EXPECT_NEAR(applied.back(), -hand, k * res);
  // On average the hand is balanced far better (Newton over the last N
  // periods: sum (applied + F) T = m (v_end - v_start), no friction or
  // damping on this device). The mass stays in a band of width W (the
  // readings' range plus one count); with |acceleration| <= A its speed is at
  // most sqrt(2 A W), else it would leave the band.
  const std::size_t window = 500;
  double sum = 0, lo = position[n - window], hi = lo, worst = 0;
  for (std::size_t i = n - window; i < n; ++i) {
    sum += applied[i];
    lo = std::min(lo, position[i]);
    hi = std::max(hi, position[i]);
    worst = std::max(worst, std::abs(applied[i] + hand));
  }
  const double v_max = std::sqrt(2.0 * worst / mass * (hi - lo + res));
  const double bound = 2.0 * mass * v_max / (static_cast<double>(window) * period);
  EXPECT_LT(bound, 0.01);
  EXPECT_NEAR(sum / static_cast<double>(window), -hand, bound);
  EXPECT_LT(peak(applied, 0, n), 20.0) << "contact never hit the torque limit";

  TempDir dir2;
  Daemon refused(dir2, config(20000, 46));
  EXPECT_EQ(refused.wait(std::chrono::seconds(30)), 2);
  const std::string log = refused.log();
  EXPECT_NE(log.find("largest stable stiffness"), std::string::npos) << log;
  // The refusal is blamed on the config's stiffness line (file:line:), and
  // says which Hulin case it checked.
  const std::string text = config(20000, 46);
  const auto stiffness_line = 1 + std::count(text.begin(), text.begin() + text.find("stiffness ="), '\n');
  EXPECT_NE(log.find("hapticd.toml:" + std::to_string(stiffness_line) + ":"), std::string::npos) << log;
  EXPECT_NE(log.find("Hulin: K = 20000 N/m with B = 46 N s/m is outside the stable region for m = 0.1 kg, "
                     "T = 1 ms, d = 1"),
            std::string::npos)
      << log;
}

// Freudenberg 4: the hand turns the wheel 5 degrees at 1 Hz, the virtual
// wheel's resonance. In phase it pumps energy in (the amplitude grows
// linearly); switched to the opposite phase it takes it out again.
TEST(Freudenberg4, ResonantExcitationPumpsOrDampsByPhase) {
  TempDir dir;
  const std::string amplitude = std::to_string(pi * 5.0 / 180.0);
  Daemon daemon(dir,
                "[device]\ndriver = \"loopback\"\n[device.loopback]\nmotion = \"rotary\"\ndamping = 0.002\n"
                "max_force = 1.2\nhand = \"mode=hold trajectory=sine amplitude=" +
                    amplitude +
                    " frequency=1 phase=0\"\n[scene]\nname = \"spring-wheel\"\nintegrator = \"exact\"\n",
                {"--record", "run.csv"});
  std::this_thread::sleep_for(std::chrono::seconds(4));
  // Continue the same sine shifted by pi, in the device's own time base.
  const auto status = daemon.ctl({"--json", "status"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  const auto reply = daemon.ctl(
      {"--json", "hand", "mode=hold", "trajectory=sine", "amplitude=" + amplitude, "frequency=1", "phase=0"});
  ASSERT_EQ(reply.exit_code, 0) << reply.err;
  const auto cycle = nlohmann::json::parse(reply.out).at("cycle").get<double>();
  const double phase = pi + 2 * pi * std::fmod(cycle * period, 1.0);
  const auto again = daemon.ctl({"hand", "mode=hold", "trajectory=sine", "amplitude=" + amplitude,
                                 "frequency=1", "phase=" + std::to_string(phase)});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto switched = static_cast<std::size_t>(cycle);
  std::this_thread::sleep_for(std::chrono::seconds(5));
  ASSERT_EQ(daemon.stop(), 0) << daemon.log();
  const auto rec = read_recording(dir.path / "run.csv");
  const auto cycles = rec.values("cycle");
  const auto virtual_position = rec.values("virtual_position_rad");
  ASSERT_GT(cycles.size(), switched + 3000);
  const auto at = [&](double c) {
    return static_cast<std::size_t>(std::lower_bound(cycles.begin(), cycles.end(), c) - cycles.begin());
  };
  const double early = peak(virtual_position, at(0), at(1000));
  const double pumped =
      peak(virtual_position, at(static_cast<double>(switched) - 1000), at(static_cast<double>(switched)));
  const double damped = peak(virtual_position, at(2.0 * static_cast<double>(switched) - 1500),
                             at(2.0 * static_cast<double>(switched) - 500));
  EXPECT_GT(pumped, 3.0 * early) << "in phase: energy pumped in";
  EXPECT_LT(damped, 0.5 * pumped) << "opposite phase: energy taken out";
}

}  // namespace
}  // namespace hapticd::e2e::physics_test
