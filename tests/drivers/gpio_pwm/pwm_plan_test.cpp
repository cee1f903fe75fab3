// PWM write ordering: every intermediate state must be one the kernel's
// pwm_apply_state() accepts (period > 0, duty_cycle <= period).
#include <gtest/gtest.h>

#include <vector>

#include "drivers/gpio_pwm/pwm_plan.hpp"
#include "drivers/gpio_pwm/sysfs_value.hpp"
#include "sim/gpio_pwm/pwm_channel_model.hpp"

namespace hapticd::drivers::gpio_pwm::pwm_plan_test {
namespace {

std::vector<PwmWrite> writes_of(const PwmTiming& current, const PwmTiming& target) {
  const PlanResult r = plan_pwm_writes(current, target);
  EXPECT_TRUE(r.ok);
  return {r.plan.begin(), r.plan.end()};
}

TEST(PwmPlan, GrowingPeriodWritesPeriodThenDuty) {
  // 20 kHz at 25 % -> 10 kHz at 90 %: duty 90 us would not fit the old 50 us period.
  EXPECT_EQ(writes_of({50'000, 12'500}, {100'000, 90'000}),
            (std::vector<PwmWrite>{{PwmAttribute::period, 100'000}, {PwmAttribute::duty_cycle, 90'000}}));
}

TEST(PwmPlan, ShrinkingPeriodWritesDutyThenPeriod) {
  // 10 kHz at 90 % -> 20 kHz at 25 %: the old duty 90 us would not fit the new 50 us period.
  EXPECT_EQ(writes_of({100'000, 90'000}, {50'000, 12'500}),
            (std::vector<PwmWrite>{{PwmAttribute::duty_cycle, 12'500}, {PwmAttribute::period, 50'000}}));
}

TEST(PwmPlan, FreshlyExportedChannelGetsItsPeriodFirst) {
  // A new channel holds period 0: a duty write first would be refused.
  EXPECT_EQ(writes_of({0, 0}, {50'000, 0}), (std::vector<PwmWrite>{{PwmAttribute::period, 50'000}}));
  EXPECT_EQ(writes_of({0, 0}, {50'000, 10}),
            (std::vector<PwmWrite>{{PwmAttribute::period, 50'000}, {PwmAttribute::duty_cycle, 10}}));
}

TEST(PwmPlan, UnchangedValuesAreNotWritten) {
  EXPECT_TRUE(writes_of({50'000, 1'000}, {50'000, 1'000}).empty());
  EXPECT_EQ(writes_of({50'000, 1'000}, {50'000, 49'000}),
            (std::vector<PwmWrite>{{PwmAttribute::duty_cycle, 49'000}}));
  EXPECT_EQ(writes_of({50'000, 1'000}, {40'000, 1'000}),
            (std::vector<PwmWrite>{{PwmAttribute::period, 40'000}}));
}

TEST(PwmPlan, DutyEqualToPeriodIsAccepted) {
  EXPECT_EQ(writes_of({50'000, 0}, {50'000, 50'000}),
            (std::vector<PwmWrite>{{PwmAttribute::duty_cycle, 50'000}}));
}

TEST(PwmPlan, RefusesTargetsTheKernelRefuses) {
  EXPECT_FALSE(plan_pwm_writes({50'000, 0}, {50'000, 50'001}).ok);
  EXPECT_FALSE(plan_pwm_writes({50'000, 0}, {0, 0}).ok);
  EXPECT_EQ(plan_pwm_writes({50'000, 0}, {0, 0}).plan.count, 0u);
}

// Every accepted (current, target) pair on a grid: each write, replayed on
// the simulated kernel channel as text, is accepted, and the channel ends on
// the target.
TEST(PwmPlan, EveryIntermediateStateIsAcceptedOnTheSimulatedKernel) {
  const std::vector<std::uint64_t> values{0, 1, 999, 1'000, 1'001, 50'000, 99'999, 100'000, 1'000'000};
  int checked = 0;
  for (std::uint64_t p0 : values) {
    for (std::uint64_t d0 : values) {
      if (!(p0 == 0 && d0 == 0) && !kernel_accepts({p0, d0})) continue;
      for (std::uint64_t p1 : values) {
        for (std::uint64_t d1 : values) {
          if (!kernel_accepts({p1, d1})) continue;
          sim::PwmChannelModel channel(sim::PwmChannelState{p0, d0, true, false});
          const PlanResult r = plan_pwm_writes({p0, d0}, {p1, d1});
          ASSERT_TRUE(r.ok);
          for (const PwmWrite& w : r.plan) {
            char text[sysfs_u64_text_size];
            const std::size_t n = format_sysfs_u64(w.value_ns, text);
            ASSERT_EQ(channel.write(to_string(w.attribute), std::string_view(text, n)), 0)
                << "(" << p0 << ", " << d0 << ") -> (" << p1 << ", " << d1 << "): " << to_string(w.attribute)
                << " = " << w.value_ns;
          }
          EXPECT_EQ(channel.state().period_ns, p1);
          EXPECT_EQ(channel.state().duty_ns, d1);
          EXPECT_EQ(r.plan.count, static_cast<std::size_t>((p0 != p1) + (d0 != d1)));
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 1000);
}

// The opposite order is what the kernel refuses: the test's model catches it
// (so the test above can fail).
TEST(PwmPlan, TheWrongOrderIsRefusedBySimulatedKernel) {
  sim::PwmChannelModel growing(sim::PwmChannelState{50'000, 12'500, true, false});
  EXPECT_EQ(growing.write("duty_cycle", "90000\n"), EINVAL);
  sim::PwmChannelModel shrinking(sim::PwmChannelState{100'000, 90'000, true, false});
  EXPECT_EQ(shrinking.write("period", "50000\n"), EINVAL);
  sim::PwmChannelModel fresh;
  EXPECT_EQ(fresh.write("duty_cycle", "0\n"), EINVAL);
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::pwm_plan_test
