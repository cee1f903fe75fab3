// The text of unsigned sysfs attributes, and unwrapping a kernel counter.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>

#include "drivers/gpio_pwm/counter_unwrap.hpp"
#include "drivers/gpio_pwm/sysfs_value.hpp"

namespace hapticd::drivers::gpio_pwm::sysfs_counter_test {
namespace {

TEST(SysfsValue, ParsesWhatTheKernelPrints) {
  EXPECT_EQ(parse_sysfs_u64("50000\n"), 50000u);
  EXPECT_EQ(parse_sysfs_u64("0\n"), 0u);
  EXPECT_EQ(parse_sysfs_u64("7"), 7u);
  EXPECT_EQ(parse_sysfs_u64("18446744073709551615\n"), std::numeric_limits<std::uint64_t>::max());
  // A plain file overwritten at offset 0 with a shorter value keeps the old tail.
  EXPECT_EQ(parse_sysfs_u64("5\n00000\n"), 5u);
}

TEST(SysfsValue, RefusesAnythingElse) {
  for (const char* text :
       {"", "\n", "-1\n", "+1\n", " 1\n", "1 \n", "12a\n", "0x10\n", "18446744073709551616\n"}) {
    EXPECT_FALSE(parse_sysfs_u64(text).has_value()) << '"' << text << '"';
  }
}

TEST(SysfsValue, FormatsWithANewline) {
  char buffer[sysfs_u64_text_size];
  EXPECT_EQ(std::string(buffer, format_sysfs_u64(12500, buffer)), "12500\n");
  EXPECT_EQ(std::string(buffer, format_sysfs_u64(0, buffer)), "0\n");
  EXPECT_EQ(std::string(buffer, format_sysfs_u64(std::numeric_limits<std::uint64_t>::max(), buffer)),
            "18446744073709551615\n");
  char small[4];
  EXPECT_EQ(format_sysfs_u64(1, small), 0u);
}

TEST(CounterUnwrap, StartsAtTheRawCountAndFollowsIt) {
  CounterUnwrap u(0xFFFFFFFFu, 1000);
  EXPECT_EQ(u.position(), 1000);
  ASSERT_TRUE(u.update(1500));
  EXPECT_EQ(u.position(), 1500);
  ASSERT_TRUE(u.update(200));
  EXPECT_EQ(u.position(), 200);
}

TEST(CounterUnwrap, WrapsForwardAndBackwardAt32Bits) {
  CounterUnwrap u(0xFFFFFFFFu, 0xFFFFFFF0u);
  ASSERT_TRUE(u.update(0x10));  // +32 through the ceiling
  EXPECT_EQ(u.position(), 0xFFFFFFF0LL + 32);
  ASSERT_TRUE(u.update(0xFFFFFFF8u));  // -24 back through zero
  EXPECT_EQ(u.position(), 0xFFFFFFF0LL + 8);
}

TEST(CounterUnwrap, SmallOddRange) {
  // ceiling 4: counts 0..4, five values; a move of +2 or -2 is unambiguous.
  CounterUnwrap u(4, 0);
  const std::uint64_t forward[] = {2, 4, 1, 3, 0};
  std::int64_t expected = 0;
  for (std::uint64_t raw : forward) {
    ASSERT_TRUE(u.update(raw));
    expected += 2;
    EXPECT_EQ(u.position(), expected) << raw;
  }
  ASSERT_TRUE(u.update(3));  // -2
  EXPECT_EQ(u.position(), expected - 2);
}

TEST(CounterUnwrap, FullSixtyFourBitRange) {
  constexpr auto top = std::numeric_limits<std::uint64_t>::max();
  CounterUnwrap u(top, 3);
  ASSERT_TRUE(u.update(top - 2));  // 3 -> -3: back by 6 through zero
  EXPECT_EQ(u.position(), -3);
  ASSERT_TRUE(u.update(top));  // +2
  EXPECT_EQ(u.position(), -1);
  ASSERT_TRUE(u.update(1));  // +2 through the top
  EXPECT_EQ(u.position(), 1);
}

// Found by fuzz_gpio_pwm_position (tests/fuzz/regressions): two jumps of
// about 2^63 back on a 64-bit counter overflowed the int64 position (UB),
// and the device negates the position when `reverse` is set.
TEST(CounterUnwrap, AMoveOutsideInt64IsRefusedNotWrapped) {
  constexpr auto top = std::numeric_limits<std::uint64_t>::max();
  CounterUnwrap u(top, 0);
  ASSERT_TRUE(u.update(std::uint64_t{1} << 63 | 1));  // back by 2^63 - 1
  EXPECT_EQ(u.position(), std::numeric_limits<std::int64_t>::min() + 1);
  EXPECT_FALSE(u.update(1));  // back by 2^63 more: outside int64
  EXPECT_EQ(u.position(), std::numeric_limits<std::int64_t>::min() + 1);
  EXPECT_EQ(u.last_raw(), std::uint64_t{1} << 63 | 1);
  EXPECT_FALSE(u.update(std::uint64_t{1} << 63));  // back by 1: INT64_MIN, which has no negation
  ASSERT_TRUE(u.update(0));                        // forward again
  EXPECT_EQ(u.position(), 0);
}

TEST(CounterUnwrap, RawAboveTheCeilingIsRefused) {
  CounterUnwrap u(1000, 10);
  EXPECT_FALSE(u.update(1001));
  EXPECT_EQ(u.position(), 10);
  EXPECT_EQ(u.last_raw(), 10u);
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::sysfs_counter_test
