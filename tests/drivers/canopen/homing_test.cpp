// CiA 402 homing, the pure parts: the driver's codec (the statusword's
// homing bits, the methods in words), its homing sequence against the
// statusword period by period, the homing keys in the drive's units, and the
// simulated drive's own homing controller against a plant.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>

#include "drivers/canopen/402/homing.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/homing.hpp"
#include "sim/canopen/homing_controller.hpp"

namespace homing_test {

namespace canopen = hapticd::drivers::canopen;
namespace cia402 = hapticd::drivers::canopen::cia402;
namespace sim = hapticd::drivers::canopen::sim;
using canopen::HomingFailure;
using canopen::HomingObservation;
using canopen::HomingPhase;
using canopen::HomingSequence;
using cia402::HomingStatus;

namespace {

// Statuswords in homing mode, Operation Enabled (0x0237: bits 0-2, 4, 5, 9),
// with the homing bits 13, 12, 10 as CiA 402 sets them.
constexpr std::uint16_t enabled = 0x0237;
constexpr std::uint16_t in_progress = enabled;
constexpr std::uint16_t not_started = enabled | 1U << 10;
constexpr std::uint16_t attained_moving = enabled | 1U << 12;
constexpr std::uint16_t completed = enabled | 1U << 12 | 1U << 10;
constexpr std::uint16_t error_at_rest = enabled | 1U << 13 | 1U << 10;

TEST(HomingCodec, EveryCombinationOfTheHomingBits) {
  EXPECT_EQ(cia402::decode_homing_status(in_progress), HomingStatus::in_progress);
  EXPECT_EQ(cia402::decode_homing_status(not_started), HomingStatus::interrupted_or_not_started);
  EXPECT_EQ(cia402::decode_homing_status(attained_moving), HomingStatus::attained_target_not_reached);
  EXPECT_EQ(cia402::decode_homing_status(completed), HomingStatus::completed);
  EXPECT_EQ(cia402::decode_homing_status(enabled | 1U << 13), HomingStatus::error_moving);
  EXPECT_EQ(cia402::decode_homing_status(error_at_rest), HomingStatus::error_at_rest);
  EXPECT_EQ(cia402::decode_homing_status(enabled | 3U << 12), HomingStatus::reserved);
  EXPECT_EQ(cia402::decode_homing_status(enabled | 3U << 12 | 1U << 10), HomingStatus::reserved);
  // Only bits 13, 12 and 10 count: the state bits and bit 11 do not.
  EXPECT_EQ(cia402::decode_homing_status(0xFFFF & ~(3U << 12) & ~(1U << 10)), HomingStatus::in_progress);
  EXPECT_EQ(cia402::to_string(HomingStatus::completed), "homing completed");
  EXPECT_EQ(cia402::homing_operation_start, 0x0010);
}

TEST(HomingCodec, MethodsInWords) {
  EXPECT_EQ(cia402::describe_homing_method(17), "on the negative limit switch");
  EXPECT_EQ(cia402::describe_homing_method(18), "on the positive limit switch");
  EXPECT_EQ(cia402::describe_homing_method(37), "on the current position");
  EXPECT_EQ(cia402::describe_homing_method(1), "on the negative limit switch and the index pulse");
  EXPECT_EQ(cia402::describe_homing_method(28), "on the home switch, negative initial motion");
  EXPECT_EQ(cia402::describe_homing_method(15), "reserved (no CiA 402 method)");
  EXPECT_EQ(cia402::describe_homing_method(-3), "manufacturer-specific");
  EXPECT_FALSE(cia402::homing_method_moves(37));
  EXPECT_FALSE(cia402::homing_method_moves(35));
  EXPECT_TRUE(cia402::homing_method_moves(17));
}

/// Feeds the sequence one statusword per period, a TPDO each; returns the phase.
struct Drive {
  HomingSequence sequence{10, 100};
  std::uint64_t tpdos = 0;
  HomingPhase period(std::uint16_t statusword, bool operational = true, bool faulted = false) {
    return sequence.step(HomingObservation{operational, faulted, statusword, ++tpdos});
  }
};

TEST(HomingSequenceTest, EnablesThenStartsThenCompletesOnBits12And10) {
  Drive r;
  EXPECT_EQ(r.period(0x0250, false), HomingPhase::enabling);  // Switch On Disabled
  EXPECT_FALSE(r.sequence.start_bit());
  EXPECT_EQ(r.period(not_started), HomingPhase::starting) << "Operation Enabled: bit 4 goes out";
  EXPECT_TRUE(r.sequence.start_bit());
  EXPECT_EQ(r.period(not_started), HomingPhase::starting) << "one TPDO after the start may predate it";
  EXPECT_EQ(r.period(in_progress), HomingPhase::homing);
  EXPECT_EQ(r.period(in_progress), HomingPhase::homing);
  EXPECT_EQ(r.period(attained_moving), HomingPhase::homing) << "attained, still stopping";
  EXPECT_TRUE(r.sequence.start_bit());
  EXPECT_EQ(r.period(completed), HomingPhase::completed);
  EXPECT_FALSE(r.sequence.start_bit());
  EXPECT_EQ(r.sequence.failure(), HomingFailure::none);
  EXPECT_EQ(r.sequence.homing_periods(), 5u);
  EXPECT_EQ(r.period(error_at_rest), HomingPhase::completed) << "done is done";
}

// A drive that homed before (and kept power) shows bits 12 and 10 until
// the new start reaches it: that is not this homing's completion.
TEST(HomingSequenceTest, ACompletionShownBeforeTheStartReachedTheDriveIsNotTaken) {
  Drive r;
  r.period(completed);  // enabled already, the old homing's bits
  EXPECT_EQ(r.sequence.phase(), HomingPhase::starting);
  EXPECT_EQ(r.period(completed), HomingPhase::starting) << "a late TPDO from before the start";
  EXPECT_EQ(r.period(in_progress), HomingPhase::homing);
  EXPECT_EQ(r.period(completed), HomingPhase::completed);
  // Homing on the current position completes within one SYNC: the second TPDO after the start says so.
  Drive quick;
  quick.period(not_started);
  quick.period(completed);
  EXPECT_EQ(quick.period(completed), HomingPhase::completed);
  EXPECT_EQ(quick.sequence.homing_periods(), 2u);
}

TEST(HomingSequenceTest, TheErrorBitInterruptionsAFaultAndTimeFail) {
  Drive error;
  error.period(not_started);
  error.period(in_progress);
  EXPECT_EQ(error.period(error_at_rest), HomingPhase::failed);
  EXPECT_EQ(error.sequence.failure(), HomingFailure::homing_error);
  EXPECT_EQ(error.sequence.last_status(), HomingStatus::error_at_rest);

  Drive interrupted;
  interrupted.period(not_started);
  interrupted.period(in_progress);
  interrupted.period(in_progress);
  EXPECT_EQ(interrupted.period(not_started), HomingPhase::failed);
  EXPECT_EQ(interrupted.sequence.failure(), HomingFailure::interrupted);

  Drive fault;
  fault.period(not_started);
  EXPECT_EQ(fault.period(in_progress, false, true), HomingPhase::failed);
  EXPECT_EQ(fault.sequence.failure(), HomingFailure::drive_fault);
  Drive left;
  left.period(not_started);
  EXPECT_EQ(left.period(0x0233, false), HomingPhase::failed) << "left Operation Enabled";
  EXPECT_EQ(left.sequence.failure(), HomingFailure::drive_fault);

  Drive reserved;
  reserved.period(not_started);
  reserved.period(in_progress);
  EXPECT_EQ(reserved.period(enabled | 3U << 12), HomingPhase::failed);
  EXPECT_EQ(reserved.sequence.failure(), HomingFailure::reserved_status);

  Drive never;  // a drive that never starts: "not started" until the time is up
  never.period(not_started);
  EXPECT_EQ(never.period(not_started), HomingPhase::starting);
  for (int i = 0; i < 99; ++i) EXPECT_EQ(never.period(not_started), HomingPhase::homing) << i;
  EXPECT_EQ(never.period(not_started), HomingPhase::failed);
  EXPECT_EQ(never.sequence.failure(), HomingFailure::timed_out);
  const auto verdict = canopen::describe(never.sequence, 1, 17, 1e-3);
  EXPECT_EQ(verdict.key, "homing_timeout");
  EXPECT_EQ(
      verdict.text,
      "node 1 homing method 17 (on the negative limit switch) did not complete after 101 periods (0.101 s) "
      "(homing_timeout); the last statusword 0x0637: homing interrupted or not started");

  Drive unenabled;
  for (int i = 0; i < 10; ++i) EXPECT_EQ(unenabled.period(0x0250, false), HomingPhase::enabling);
  EXPECT_EQ(unenabled.period(0x0250, false), HomingPhase::failed);
  EXPECT_EQ(unenabled.sequence.failure(), HomingFailure::not_enabled);
  EXPECT_EQ(canopen::describe(error.sequence, 1, 17, 1e-3).key, "homing_method");
}

TEST(HomingSettingsTest, TheSiKeysInTheDrivesUnitsAndWhatDoesNotFit) {
  canopen::CanopenConfig c;
  c.interface = "can0";
  c.counts_per_unit = 16384;
  c.homing = true;
  c.homing_method = 17;
  c.home_offset = 0.25;  // rad
  c.homing_speed_switch = 1.0;
  c.homing_speed_zero = 0.2;
  c.homing_acceleration = 10.0;
  const auto h = canopen::homing_settings(c);
  const double per_rad = 16384 / (2 * std::numbers::pi);
  EXPECT_EQ(h.method, 17);
  EXPECT_EQ(h.home_offset_counts, std::lround(0.25 * per_rad));
  EXPECT_EQ(h.speed_switch, static_cast<std::uint32_t>(std::lround(1.0 * per_rad)));
  EXPECT_EQ(h.speed_zero, static_cast<std::uint32_t>(std::lround(0.2 * per_rad)));
  EXPECT_EQ(h.acceleration, static_cast<std::uint32_t>(std::lround(10.0 * per_rad)));
  c.reversed = true;
  EXPECT_EQ(canopen::homing_settings(c).home_offset_counts, -std::lround(0.25 * per_rad))
      << "the drive's frame";
  c.homing_speed_zero = 0.0;
  EXPECT_FALSE(canopen::homing_settings(c).speed_zero.has_value()) << "0: the drive's own";

  auto refused_key = [](canopen::CanopenConfig bad) {
    try {
      canopen::validate(bad);
    } catch (const canopen::ConfigError& e) {
      return e.key();
    }
    return std::string();
  };
  canopen::CanopenConfig slow = c;
  slow.homing_speed_switch = 1e-6;  // under one 0x6099 unit
  EXPECT_EQ(refused_key(slow), "homing_speed_switch");
  canopen::CanopenConfig far = c;
  far.home_offset = 1e6;  // 2.6e9 increments: beyond INTEGER32
  EXPECT_EQ(refused_key(far), "home_offset");
  canopen::CanopenConfig off = far;
  off.homing = false;
  EXPECT_EQ(refused_key(off), "") << "not homing: the homing keys are not converted";
}

/// A free inertia of 0.01 kg m^2 with a little damping, stepped as the drive's plant.
struct Wheel {
  double x = 0.0, v = 0.0;
  void step(double force, double dt) {
    const double a = (force - 0.002 * v) / 0.01;
    x += v * dt + 0.5 * a * dt * dt;
    v += a * dt;
  }
};

sim::HomingObjects objects(std::int8_t method) {
  sim::HomingObjects o;
  o.method = method;
  o.speed_switch = 1.0;
  o.speed_zero = 0.2;
  o.acceleration = 10.0;
  o.max_force = 3.0;
  return o;
}

constexpr double dt = 1e-3;
constexpr std::uint16_t start = 0x001F, enable = 0x000F;

TEST(SimulatedDriveHoming, OnTheCurrentPositionTheHomeIsWhereItStandsAtOnce) {
  sim::HomingController h;
  EXPECT_EQ(h.status_bits(0.0), 1U << 10) << "not started";
  h.on_controlword(enable, start, 0.3);
  EXPECT_EQ(h.status_bits(0.0), 0U) << "in progress";
  EXPECT_EQ(h.step(0.3, 0.0, objects(37), dt), 0.0);
  EXPECT_EQ(h.status_bits(0.0), (1U << 12) | (1U << 10)) << "completed";
  EXPECT_EQ(h.take_home(), 0.3);
  EXPECT_FALSE(h.take_home().has_value());
  h.on_controlword(start, enable, 0.3);
  EXPECT_EQ(h.status_bits(0.0), (1U << 12) | (1U << 10)) << "attained stays until the next start";
  h.on_controlword(enable, start, 0.3);
  EXPECT_EQ(h.status_bits(0.0), 0U) << "a new start clears it";
}

TEST(SimulatedDriveHoming, OnTheNegativeLimitSwitchTheHomeIsItsEdgeAndTheDriveStops) {
  sim::HomingController h({-0.5, 0.5}, 0.01 * 2 * std::numbers::pi * 20);
  EXPECT_TRUE(h.has_method(17));
  EXPECT_TRUE(h.has_method(18));
  EXPECT_FALSE(h.has_method(1)) << "no index pulse here";
  Wheel w;
  h.on_controlword(enable, start, w.x);
  std::optional<double> home;
  bool switch_seen = false, attained_while_moving = false;
  int n = 0;
  for (; n < 10000 && h.status_bits(w.v) != ((1U << 12) | (1U << 10)); ++n) {
    const double f = h.step(w.x, w.v, objects(17), dt);
    EXPECT_LE(std::abs(f), 3.0);
    if (!home) home = h.take_home();
    switch_seen = switch_seen || (h.digital_inputs(w.x) & 1U) != 0;
    attained_while_moving = attained_while_moving || h.status_bits(w.v) == (1U << 12);
    w.step(f, dt);
  }
  ASSERT_TRUE(home.has_value());
  EXPECT_TRUE(switch_seen);
  EXPECT_TRUE(attained_while_moving) << "bit 12 before bit 10 while it stops";
  EXPECT_GT(*home, -0.5) << "off the switch";
  EXPECT_LT(*home, -0.5 + 0.2 * dt * 2) << "at its edge, within a period of the zero search speed";
  EXPECT_LT(std::abs(w.v), 1e-3);
  EXPECT_LT(n, 2000) << "0.5 rad at 1 rad/s, back at 0.2 rad/s";
  EXPECT_EQ(h.digital_inputs(-0.6), 1U);
  EXPECT_EQ(h.digital_inputs(0.6), 2U);
}

TEST(SimulatedDriveHoming, TheOtherSidesSwitchIsAHomingError) {
  sim::HomingController h({-0.5, 0.5}, 0.01 * 2 * std::numbers::pi * 20);
  Wheel w;
  w.x = 0.6;  // beyond the positive switch already
  h.on_controlword(enable, start, w.x);
  h.step(w.x, w.v, objects(17), dt);
  EXPECT_EQ(h.status_bits(0.0), (1U << 13) | (1U << 10)) << "error, at rest";
  EXPECT_EQ(h.status_bits(0.5), 1U << 13) << "error, moving";
  sim::HomingController bare;
  EXPECT_FALSE(bare.has_method(17)) << "no switch, no method 17";
  bare.on_controlword(enable, start, 0.0);
  bare.step(0.0, 0.0, objects(17), dt);
  EXPECT_NE(bare.status_bits(0.0) & (1U << 13), 0U);
}

TEST(SimulatedDriveHoming, BitFourFallingOrHaltInterrupts) {
  sim::HomingController h({-0.5, 0.5}, 0.01 * 2 * std::numbers::pi * 20);
  Wheel w;
  h.on_controlword(enable, start, w.x);
  for (int i = 0; i < 50; ++i) w.step(h.step(w.x, w.v, objects(17), dt), dt);
  EXPECT_EQ(h.status_bits(w.v), 0U);
  h.on_controlword(start, start | 0x100, w.x);  // halt
  EXPECT_EQ(h.status_bits(w.v), 1U << 10) << "interrupted";
  h.on_controlword(start | 0x100, start, w.x);
  EXPECT_EQ(h.status_bits(w.v), 1U << 10) << "no new edge: still interrupted";
}

}  // namespace

}  // namespace homing_test
