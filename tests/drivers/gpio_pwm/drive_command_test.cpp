// Sign/magnitude split of a force into direction + PWM duty.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "drivers/gpio_pwm/drive_command.hpp"

namespace hapticd::drivers::gpio_pwm::drive_command_test {
namespace {

// 0.8 N m at full duty, 95 % maximum, 10 mN m deadband, 20 kHz.
constexpr DriveScaling scaling{0.8, 0.95, 0.01, 50'000};

TEST(DriveCommand, SignSelectsDirectionMagnitudeSelectsDuty) {
  const DriveResult up = split_force(0.2, scaling, false);
  EXPECT_TRUE(up.valid);
  EXPECT_EQ(up.command, (DriveCommand{true, 12'500, false}));  // 0.2 / 0.8 = 25 % of 50 us
  const DriveResult down = split_force(-0.4, scaling, true);
  EXPECT_EQ(down.command, (DriveCommand{false, 25'000, false}));
}

TEST(DriveCommand, InsideTheDeadbandDutyIsZeroAndDirectionHeld) {
  EXPECT_EQ(split_force(0.0, scaling, true).command, (DriveCommand{true, 0, false}));
  EXPECT_EQ(split_force(0.0, scaling, false).command, (DriveCommand{false, 0, false}));
  EXPECT_EQ(split_force(-0.01, scaling, true).command, (DriveCommand{true, 0, false}));  // |F| = deadband
  EXPECT_EQ(split_force(0.01, scaling, false).command, (DriveCommand{false, 0, false}));
  // Just outside: the full magnitude, not magnitude - deadband.
  const DriveResult out = split_force(-0.0101, scaling, true);
  EXPECT_EQ(out.command, (DriveCommand{false, 631, false}));  // 0.0101 / 0.8 * 50000 = 631.25
}

TEST(DriveCommand, MaxDutyLimitsAndSays) {
  const DriveResult r = split_force(5.0, scaling, true);
  EXPECT_EQ(r.command, (DriveCommand{true, 47'500, true}));
  EXPECT_EQ(split_force(-0.6, scaling, true).command,
            (DriveCommand{false, 37'500, false}));  // 75 %: below the limit
}

TEST(DriveCommand, DutyNeverExceedsThePeriod) {
  constexpr DriveScaling full{1.0, 1.0, 0.0, 3};
  EXPECT_EQ(split_force(1e300, full, true).command.duty_ns, 3u);
  EXPECT_EQ(split_force(0.5, full, true).command.duty_ns, 2u);  // 1.5 rounds to nearest (away from zero)
  EXPECT_EQ(split_force(0.49, full, true).command.duty_ns, 1u);
}

TEST(DriveCommand, NonFiniteForceGivesZeroDutyAndInvalid) {
  for (double f : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                   -std::numeric_limits<double>::infinity()}) {
    const DriveResult r = split_force(f, scaling, false);
    EXPECT_FALSE(r.valid);
    EXPECT_EQ(r.command, (DriveCommand{false, 0, false}));
  }
}

TEST(DriveCommand, ForceOfInvertsTheSplitToTheNanosecond) {
  for (double f : {-0.76, -0.3, -0.0123, 0.05, 0.4, 0.7}) {
    const DriveCommand c = split_force(f, scaling, true).command;
    EXPECT_NEAR(force_of(c, scaling), f, 0.5 * scaling.force_at_full_duty / 50'000.0) << f;
  }
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::drive_command_test
