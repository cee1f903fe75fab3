// Hannaford & Ryu's passivity observer and controller (world/passivity_observer.hpp)
// on synthetic port signals and on a simulated device (a 0.1 kg mass under a
// zero-order hold) with an active environment.
#include "world/passivity_observer.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/alloc_counter.hpp"

namespace hapticd::world::passivity_observer_test {
namespace {

constexpr double t = 1e-3;
constexpr double pi = std::numbers::pi;

PassivityObserverConfig config(double max_damping, std::size_t window = 0) {
  PassivityObserverConfig c;
  c.period_s = t;
  c.max_damping = max_damping;
  c.velocity_floor = velocity_floor_for(1e-6, t);  // a 1 um encoder: 1 mm/s
  c.window_periods = window;
  return c;
}

/// A device trajectory with direction changes: y(n) = a sin(2 pi f n T) + ...
double trajectory(int n) {
  const double s = n * t;
  return 0.01 * std::sin(2 * pi * 1.3 * s) + 0.003 * std::sin(2 * pi * 7.1 * s + 0.4);
}

// ---------------------------------------------------------------------------
// Passive environments, H&R's pairing (force computed from y[n], v[n] the
// backward difference): a damper adds B T v^2 per period; a spring 1/2 K dy^2
// beyond what it stores (K y[n] (y[n] - y[n-1]) - 1/2 K (y[n]^2 - y[n-1]^2)).

TEST(PassivityObserver, PassiveEnvironmentsNeverTriggerTheController) {
  struct Environment {
    const char* name;
    double k, b;
  };
  for (const Environment e : {Environment{"damper", 0.0, 5.0}, Environment{"spring", 2000.0, 0.0},
                              Environment{"spring-damper", 9000.0, 46.0}}) {
    for (const std::size_t window : {std::size_t{0}, std::size_t{30}}) {
      PassivityObserver<> po(config(50.0, window));
      double previous = trajectory(0);
      po.reset(0.5 * e.k * previous * previous);  // the spring holds this at the start
      double energy = 0.0;
      for (int n = 1; n < 20000; ++n) {
        const double y = trajectory(n), v = (y - previous) / t;
        previous = y;
        const PassivityStep s = po.step(-e.k * y - e.b * v, v, 0.5 * e.k * y * y);
        ASSERT_EQ(s.damping, 0.0) << e.name << " window " << window << " n " << n;
        ASSERT_GE(po.unstored_energy(), 0.0) << e.name;
        energy = po.energy();
      }
      EXPECT_GT(energy, 0.0) << e.name;
    }
  }
}

// Why the stored energy is passed: with forgetting, a spring held compressed
// longer than the window has its compression energy forgotten, and giving it
// back on release reads as generated energy. Counted as the environment's
// (not credit, not forgettable), the same spring never triggers.
TEST(PassivityObserver, StoredSpringEnergyIsNotForgottenCredit) {
  const double k = 5000.0;
  const auto run = [&](bool pass_stored) {
    PassivityObserver<> po(config(50.0, 30));
    double previous = 0.0;
    int triggered = 0;
    for (int n = 1; n < 3000; ++n) {
      // Press in over 200 ms, hold 1 s, release over 200 ms.
      const double s = n * t;
      const double y = s < 0.2 ? 0.01 * s / 0.2 : (s < 1.2 ? 0.01 : std::max(0.0, 0.01 * (1.4 - s) / 0.2));
      const double v = (y - previous) / t;
      previous = y;
      triggered += po.step(-k * y, v, pass_stored ? 0.5 * k * y * y : 0.0).damping > 0.0;
    }
    return triggered;
  };
  EXPECT_EQ(run(true), 0);
  EXPECT_GT(run(false), 0);
}

// ---------------------------------------------------------------------------
// The controller's arithmetic.

TEST(PassivityObserver, DampingIsBoundedAndEnergyCorrectedOnlyByWhatWasDissipated) {
  const double max_damping = 2.0;
  PassivityObserver<> po(config(max_damping));
  double previous = trajectory(0);
  bool clamped = false;
  for (int n = 1; n < 5000; ++n) {
    const double y = trajectory(n), v = (y - previous) / t;
    previous = y;
    const double before = po.unstored_energy();
    const double force = 30.0 * v;  // a negative damper: generates 30 v^2 W
    const PassivityStep s = po.step(force, v);
    ASSERT_LE(s.damping, max_damping);
    ASSERT_GE(s.damping, 0.0);
    EXPECT_DOUBLE_EQ(s.dissipated, s.damping * t * v * v);
    EXPECT_EQ(s.force, -s.damping * v);
    EXPECT_DOUBLE_EQ(po.unstored_energy(), before - t * force * v + s.dissipated);
    clamped = clamped || s.damping == max_damping;
  }
  EXPECT_TRUE(clamped);  // 30 N s/m of activity against a 2 N s/m device: E keeps falling
  EXPECT_LT(po.energy(), 0.0);

  // Enough damping available: E is brought back to 0 exactly each period.
  PassivityObserver<> strong(config(100.0));
  previous = trajectory(0);
  for (int n = 1; n < 5000; ++n) {
    const double y = trajectory(n), v = (y - previous) / t;
    previous = y;
    const PassivityStep s = strong.step(30.0 * v, v);
    if (std::abs(v) >= 1e-3) {  // above the floor: alpha = -E / (T v^2) dissipates all of E
      EXPECT_NEAR(strong.energy(), 0.0, 1e-15) << n;
      EXPECT_GE(s.damping, 30.0 - 1e-9) << n;  // more after a floored period left some of E
    }
    ASSERT_GE(strong.energy(), -30.0 * t * 1e-6 * 20) << n;  // below the floor (1 mm/s): a few periods' worth
  }
}

// A wall stiffer than Hulin's limit (20 kN/m; 14.4 kN/m at d = 1 on 0.1 kg),
// one sample late, pressed 1.5 mm deep twice a second on a set trajectory:
// it returns more than it took (E falls by 13 mJ without the controller).
// With it, and the wall's 1/2 K x^2 reported as stored, E stays at 0 (to
// rounding): the activity is caught while pressing in. Without the stored
// energy the observer sees it only on the way out, where the damper (at most
// 200 N s/m) cannot take it all back: E falls by 16 mJ.
TEST(PassivityController, KeepsADelayedStiffWallPassiveOnASyntheticTrajectory) {
  const double k = 20000.0;
  const auto run = [&](bool control, bool report_stored) {
    PassivityObserverConfig c = config(200.0, 50);
    c.control = control;
    PassivityObserver<> po(c);
    double previous = 0.0, held = 0.0, late = 0.0, lowest = 0.0;
    for (int n = 1; n < 4000; ++n) {
      const double y = 0.002 * std::sin(2 * pi * 2.0 * n * t) - 0.0005;  // in contact where y > 0
      const double dy = y - previous;
      previous = y;
      const double stored = report_stored && late > 0.0 ? 0.5 * k * late * late : 0.0;
      po.step(held, dy / t, stored);        // `held`: the force over the period that just ended
      held = late > 0.0 ? -k * late : 0.0;  // the law on the position one sample ago
      late = y;
      lowest = std::min(lowest, po.energy());
    }
    return lowest;
  };
  EXPECT_LT(run(false, true), -0.01);
  EXPECT_GE(run(true, true), -1e-12);
  EXPECT_LT(run(true, false), -0.01);
}

// One count a period is quantization: inside the deadband the controller
// keeps D for later and adds no force (else it dithers the device).
TEST(PassivityObserver, DeadbandLeavesOneCountMotionAlone) {
  PassivityObserverConfig c = config(30.0);
  c.velocity_deadband = 1.5 * 3.14e-6 / t;  // 1.5 counts of 3.14 um a period
  PassivityObserver<> po(c);
  po.step(10.0, 0.1);  // E = -1e-3 J
  const double e = po.energy();
  for (const double v : {3.14e-3, -3.14e-3, 0.0}) {
    const PassivityStep s = po.step(0.0, v);
    EXPECT_EQ(s.damping, 0.0) << v;
    EXPECT_EQ(s.force, 0.0) << v;
  }
  EXPECT_EQ(po.energy(), e);
  const PassivityStep fast = po.step(0.0, 2.0 * 3.14e-3);  // two counts: acts
  EXPECT_EQ(fast.damping, 30.0);
  EXPECT_NEAR(fast.force, -30.0 * 6.28e-3, 1e-12);
  PassivityObserverConfig bad = config(30.0);
  bad.velocity_deadband = -1.0;
  EXPECT_THROW(PassivityObserver<> refused(bad), std::invalid_argument);
}

TEST(PassivityObserver, ZeroVelocityDoesNotDivideByZero) {
  PassivityObserver<> po(config(7.0));
  po.step(10.0, 0.1);  // the environment pushed the moving device: E = -1e-3 J
  ASSERT_LT(po.energy(), 0.0);
  const double e = po.energy();
  const PassivityStep s = po.step(0.0, 0.0);
  EXPECT_TRUE(std::isfinite(s.damping));
  EXPECT_EQ(s.damping, 7.0);  // -E / (T floor^2) = 1e3 N s/m, clamped
  EXPECT_EQ(s.force, 0.0);
  EXPECT_EQ(s.dissipated, 0.0);
  EXPECT_EQ(po.energy(), e);  // nothing dissipated, nothing corrected

  PassivityObserverConfig tiny = config(7.0);
  tiny.velocity_floor = 1e-300;  // squares to 0 in double: floored at the smallest normal
  PassivityObserver<> po2(tiny);
  po2.step(10.0, 0.1);
  const PassivityStep s2 = po2.step(0.0, 0.0);
  EXPECT_EQ(s2.damping, 7.0);
  EXPECT_FALSE(std::isnan(po2.energy()));
}

TEST(PassivityObserver, NonFiniteSamplesAreSkipped) {
  PassivityObserver<> po(config(7.0));
  po.step(-1.0, 0.5);
  const double e = po.energy();
  for (const double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(po.step(bad, 0.1).damping, 0.0);
    EXPECT_EQ(po.step(1.0, bad).damping, 0.0);
    EXPECT_EQ(po.step(1.0, 0.1, bad).damping, 0.0);
  }
  EXPECT_EQ(po.step(1.0, 0.1, -1.0).damping, 0.0);
  EXPECT_EQ(po.energy(), e);
  EXPECT_EQ(po.rejected(), 7u);
}

// Measured correction: the damper's force is booked with the next period's
// displacement, and nothing at once.
TEST(PassivityObserver, MeasuredCorrectionBooksTheDampersRealWork) {
  PassivityObserverConfig c = config(100.0);
  c.correction = PassivityCorrection::measured;
  PassivityObserver<> po(c);
  const PassivityStep first = po.step(10.0, 0.1);  // generated 1e-3 J: alpha = 1e-3 / (T 0.01) = 100
  EXPECT_DOUBLE_EQ(first.damping, 100.0);
  EXPECT_DOUBLE_EQ(first.force, -10.0);
  EXPECT_EQ(first.dissipated, 0.0);  // nothing booked yet
  EXPECT_DOUBLE_EQ(po.energy(), -1e-3);
  // The velocity reversed under the held damper force: it did -T (-10)(-0.05) = -5e-4 J.
  const PassivityStep second = po.step(0.0, -0.05);
  EXPECT_DOUBLE_EQ(second.dissipated, -5e-4);
  EXPECT_DOUBLE_EQ(po.energy(), -1.5e-3);
  EXPECT_EQ(second.damping, 100.0);  // clamped: 1.5e-3 / (T 0.0025) = 600
}

TEST(PassivityObserver, ObserverOnlyNeverDamps) {
  PassivityObserverConfig c = config(100.0);
  c.control = false;
  PassivityObserver<> po(c);
  double energy = 0.0;
  for (int n = 0; n < 100; ++n) {
    EXPECT_EQ(po.step(30.0 * 0.1, 0.1).damping, 0.0);
    energy -= t * 30.0 * 0.1 * 0.1;
  }
  EXPECT_NEAR(po.energy(), energy, 1e-15);
}

TEST(PassivityObserver, ConfigIsChecked) {
  PassivityObserverConfig c = config(1.0, 10);
  c.period_s = 0.0;
  EXPECT_THROW(PassivityObserver<> x(c), std::invalid_argument);
  c = config(-1.0);
  EXPECT_THROW(PassivityObserver<> x(c), std::invalid_argument);
  c = config(1.0);
  c.velocity_floor = 0.0;
  EXPECT_THROW(PassivityObserver<> x(c), std::invalid_argument);
  c = config(1.0, 257);
  EXPECT_THROW(PassivityObserver<256> x(c), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// Forgetting: a long dissipative contact builds a credit; with a window the
// controller answers an active turn within about the window, without it only
// after the active environment has used the whole credit up.
TEST(PassivityObserver, ForgettingDissipatedEnergyShortensTheDelay) {
  const auto first_trigger = [](std::size_t window) {
    PassivityObserver<> po(config(100.0, window));
    double previous = trajectory(0);
    for (int n = 1; n < 20000; ++n) {
      const double y = trajectory(n), v = (y - previous) / t;
      previous = y;
      const double b = n < 5000 ? 20.0 : -20.0;  // 5 s of a damper, then a negative one
      if (po.step(-b * v, v).damping > 0.0) return n - 5000;
    }
    return 1 << 30;
  };
  const int with_window = first_trigger(50), without = first_trigger(0);
  EXPECT_GE(with_window, 0);
  EXPECT_LT(with_window, 100);
  EXPECT_GT(without, 10 * with_window + 1000);
}

// ---------------------------------------------------------------------------
// Closed loop: a 0.1 kg mass (no physical damping) under a zero-order hold,
// a spring K = 2000 N/m rendered 2 samples late (Hulin: no stiffness is stable
// with d >= 0 and no damping), started 1 cm out with the spring's 0.1 J in it.
// The observer gets the force held over the last period and the
// displacement over it (the exact work), no stored energy (the delayed
// spring has no storage function: crediting 1/2 F^2/K made the controller
// clamp half the time), a 50-period window.

struct LoopRun {
  double first_amplitude = 0.0;  ///< max |x| over the first second
  double last_amplitude = 0.0;   ///< ... over the last second
  double min_observed = 0.0;     ///< min of the observer's E
  double min_port_energy = 0.0;  ///< min of the work the device did on environment + controller, J
  double max_damping = 0.0;
  double largest_mismatch = 0.0;  ///< max |E - port energy|, J
};

LoopRun delayed_spring(bool control, double max_damping, PassivityCorrection correction) {
  constexpr double m = 0.1, k = 2000.0;
  constexpr int d = 2, periods = 10000;
  PassivityObserverConfig c = config(max_damping, 50);
  c.control = control;
  c.correction = correction;
  PassivityObserver<> po(c);
  double x = 0.01, v = 0.0;
  std::vector<double> line(d + 1, -k * x);  // the spring's force, d samples late
  double held = line.front(), previous = x, port = 0.0;
  LoopRun r;
  for (int n = 0; n < periods; ++n) {
    const double y = x;
    const double dy = y - previous;
    previous = y;
    // The period that just ended: the environment's force `held` moved the device by dy.
    const PassivityStep s = po.step(held, dy / t);
    r.min_observed = std::min(r.min_observed, po.energy());
    r.largest_mismatch = std::max(r.largest_mismatch, std::abs(po.energy() - port));
    line.erase(line.begin());
    line.push_back(-k * y);
    held = line.front();
    const double out = held + s.force;
    // ZOH on the mass: exact for a held force.
    const double x_next = x + v * t + out * t * t / (2 * m);
    v += out * t / m;
    port += -out * (x_next - x);
    x = x_next;
    r.min_port_energy = std::min(r.min_port_energy, port);
    r.max_damping = std::max(r.max_damping, s.damping);
    if (n < 1000) r.first_amplitude = std::max(r.first_amplitude, std::abs(x));
    if (n >= periods - 1000) r.last_amplitude = std::max(r.last_amplitude, std::abs(x));
  }
  return r;
}

TEST(PassivityController, MakesADelayedSpringPassive) {
  const double initial = 0.5 * 2000.0 * 0.01 * 0.01;  // 0.1 J in the spring at the start
  const LoopRun off = delayed_spring(false, 0.0, PassivityCorrection::measured);
  EXPECT_GT(off.last_amplitude, 3.0 * off.first_amplitude);  // grows without the controller
  EXPECT_LT(off.min_observed, -10.0 * initial);              // and the observer saw it generate energy
  EXPECT_LT(off.largest_mismatch, 1e-9 * std::abs(off.min_observed));  // the held-force pairing is exact

  const double max_damping = 20.0;
  for (const PassivityCorrection correction :
       {PassivityCorrection::measured, PassivityCorrection::estimated}) {
    const LoopRun on = delayed_spring(true, max_damping, correction);
    EXPECT_LE(on.max_damping, max_damping);
    EXPECT_GT(on.max_damping, 0.0);
    EXPECT_LT(on.last_amplitude, 1e-3 * on.first_amplitude);  // the oscillation dies out
    // Passive: the device never got more than the 0.1 J the spring held at the start.
    EXPECT_GE(on.min_port_energy, -initial);
    EXPECT_GE(on.min_observed, -initial);
  }
  // Measured, the observer's E is the port energy itself.
  const LoopRun measured = delayed_spring(true, max_damping, PassivityCorrection::measured);
  EXPECT_LT(measured.largest_mismatch, 1e-12);
}

// With the force held over the period, a sampled spring is active by
// 1/2 K dy^2 per period, and the controller adds exactly Colgate's K T / 2.
TEST(PassivityController, HeldForcePairingAddsColgatesKTOverTwo) {
  const double k = 9000.0;
  PassivityObserver<> po(config(1e3));
  double previous = trajectory(0), held = -k * previous, previous_v = 0.0;
  po.reset(0.5 * k * previous * previous);
  int checked = 0;
  for (int n = 1; n < 3000; ++n) {
    const double y = trajectory(n), dy = y - previous, v = dy / t;
    previous = y;
    const PassivityStep s = po.step(held, v, 0.5 * k * y * y);
    held = -k * y;
    // Above the floor now and in the period before (a floored one leaves some E for the next).
    if (std::abs(v) > 2e-3 && std::abs(previous_v) > 2e-3) {
      EXPECT_NEAR(s.damping, k * t / 2.0, 1e-6 * k * t) << n;
      ++checked;
    }
    previous_v = v;
  }
  EXPECT_GT(checked, 2500);
}

// The RT step allocates nothing.
TEST(PassivityObserver, StepDoesNotAllocate) {
  ASSERT_TRUE(testing::allocation_counting_active());
  PassivityObserver<> po(config(10.0, 100));
  double sum = 0.0;
  std::size_t allocations = 0;
  {
    const testing::AllocationGuard guard;
    double previous = 0.0;
    for (int n = 1; n < 10000; ++n) {
      const double y = 0.01 * std::sin(0.01 * n), v = (y - previous) / t;
      previous = y;
      sum += po.step(25.0 * v, v, 0.5 * y * y).force;
    }
    po.reset();
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_TRUE(std::isfinite(sum));
}

}  // namespace
}  // namespace hapticd::world::passivity_observer_test
