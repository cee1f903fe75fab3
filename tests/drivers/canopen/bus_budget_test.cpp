// The bus budget: worst-case frame lengths (Davis et al. 2007, 11-bit ids)
// and the refusal line with the figure.
#include <gtest/gtest.h>

#include <array>

#include "drivers/canopen/301/bus_budget.hpp"

namespace bus_budget_test {

namespace co = hapticd::drivers::canopen::cia301;

TEST(CanopenBusBudget, WorstCaseFrameBits) {
  // 47 fixed + 8 s data bits + floor((34 + 8 s - 1) / 4) stuff bits, worked by hand:
  EXPECT_EQ(co::frame_bits_worst_case(0), 55U);   // SYNC: 47 + 0 + 8
  EXPECT_EQ(co::frame_bits_worst_case(1), 65U);   // heartbeat: 47 + 8 + 10
  EXPECT_EQ(co::frame_bits_worst_case(4), 95U);   // RPDO controlword + target torque: 47 + 32 + 16
  EXPECT_EQ(co::frame_bits_worst_case(6), 115U);  // TPDO statusword + position: 47 + 48 + 20
  EXPECT_EQ(co::frame_bits_worst_case(8), 135U);  // 47 + 64 + 24
}

namespace {
const std::array<co::CyclicFrame, 3> cycle = {{{"SYNC", 0}, {"RPDO1", 4}, {"TPDO1", 6}}};
}

TEST(CanopenBusBudget, OneMillisecondFitsAtHalfAMegabit) {
  const co::BusBudget b = co::check_bus_budget(cycle, 1e-3, 500000);
  EXPECT_EQ(b.cyclic_bits, 265U);
  EXPECT_EQ(b.total_bits, 400U);  // + one 8-byte frame of blocking
  EXPECT_DOUBLE_EQ(b.bus_time_s, 0.8e-3);
  EXPECT_TRUE(b.fits);
  EXPECT_EQ(
      b.summary,
      "3 frames (SYNC + RPDO1 + TPDO1) = 265 bits worst case, + 135 bits for one frame of other traffic = "
      "0.8 ms at 500 kbit/s, within the 1 ms period");
}

TEST(CanopenBusBudget, RefusalNamesTheBitRateThatWouldCarryIt) {
  const co::BusBudget b = co::check_bus_budget(cycle, 1e-3, 250000);
  EXPECT_FALSE(b.fits);
  EXPECT_EQ(b.needed_bitrate, 500000U);
  EXPECT_EQ(
      b.summary,
      "3 frames (SYNC + RPDO1 + TPDO1) = 265 bits worst case, + 135 bits for one frame of other traffic = "
      "1.6 ms at 250 kbit/s: a 1 ms period needs 500 kbit/s; the shortest period at 250 kbit/s is 1.6 ms");
}

TEST(CanopenBusBudget, APeriodNoClassicCanCarries) {
  const co::BusBudget b = co::check_bus_budget(cycle, 250e-6, 1000000);
  EXPECT_FALSE(b.fits);
  EXPECT_EQ(b.needed_bitrate, 0U);
  EXPECT_EQ(
      b.summary,
      "3 frames (SYNC + RPDO1 + TPDO1) = 265 bits worst case, + 135 bits for one frame of other traffic = "
      "0.4 ms at 1 Mbit/s: a 0.25 ms period needs 1.6 Mbit/s, above classic CAN's 1 Mbit/s; the shortest "
      "period at 1 Mbit/s is 0.4 ms");
  EXPECT_THROW(co::check_bus_budget(cycle, 0.0, 1000000), std::invalid_argument);
  EXPECT_THROW(co::check_bus_budget(cycle, 1e-3, 0), std::invalid_argument);
}

TEST(CanopenBusBudget, VelocityTpdoAddsAFrame) {
  const std::array<co::CyclicFrame, 4> with_velocity = {
      {{"SYNC", 0}, {"RPDO1", 4}, {"TPDO1", 6}, {"TPDO2", 4}}};
  const co::BusBudget b = co::check_bus_budget(with_velocity, 1e-3, 500000);
  EXPECT_EQ(b.cyclic_bits, 360U);
  EXPECT_DOUBLE_EQ(b.bus_time_s, 495.0 / 500000.0);
  EXPECT_TRUE(b.fits);
}

TEST(CanopenBusBudget, APeriodExactlyTheBusTimeFitsThoughTheDurationIsNotExactInBinary) {
  // "400us" in a config is 400 * 1e-6 s, a hair below 400 bit times of 1 us:
  // the 400 bits of the cycle fill it exactly and fit (they were refused with
  // "a 0.4 ms period needs 1 Mbit/s, above classic CAN's 1 Mbit/s").
  const double period_s = 400 * 1e-6;
  ASSERT_LT(period_s * 1e6, 400.0);
  const co::BusBudget b = co::check_bus_budget(cycle, period_s, 1000000);
  EXPECT_TRUE(b.fits) << b.summary;
  EXPECT_EQ(b.needed_bitrate, 1000000U);
  EXPECT_EQ(
      b.summary,
      "3 frames (SYNC + RPDO1 + TPDO1) = 265 bits worst case, + 135 bits for one frame of other traffic = "
      "0.4 ms at 1 Mbit/s, within the 0.4 ms period");
  // 800 kbit/s carries a 500 us period (400 bits = 500 us) the same way.
  EXPECT_TRUE(co::check_bus_budget(cycle, 500 * 1e-6, 800000).fits);
  // One bit time less is still refused.
  EXPECT_FALSE(co::check_bus_budget(cycle, 399 * 1e-6, 1000000).fits);
}

}  // namespace bus_budget_test
