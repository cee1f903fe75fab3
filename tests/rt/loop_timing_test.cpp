#include "rt/loop_timing.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace loop_timing_test {

using hapticd::rt::Nanos;
using hapticd::rt::PeriodicSchedule;
using hapticd::rt::RealClock;
using hapticd::rt::VirtualClock;
using namespace std::chrono_literals;

TEST(PeriodicSchedule, RejectsPeriodsOutsideTheSupportedRange) {
  VirtualClock clock;
  EXPECT_THROW(PeriodicSchedule(clock, 99us), std::invalid_argument);
  EXPECT_THROW(PeriodicSchedule(clock, 10001us), std::invalid_argument);
  EXPECT_NO_THROW(PeriodicSchedule(clock, 100us));
  EXPECT_NO_THROW(PeriodicSchedule(clock, 10ms));
}

TEST(PeriodicSchedule, DeadlinesAreAbsoluteMultiplesOfThePeriod) {
  VirtualClock clock(Nanos{5'000'000'123});
  PeriodicSchedule s(clock, 1ms);
  s.start();
  for (std::uint64_t n = 1; n <= 5000; ++n) {
    clock.advance(300us);  // compute time must not shift the deadlines
    const auto w = s.wait_next();
    ASSERT_EQ(w.deadline, Nanos{5'000'000'123} + n * Nanos{1ms});
    ASSERT_EQ(w.period_index, n);
    ASSERT_EQ(w.cycle, n);
    ASSERT_EQ(w.latency, Nanos{0});
    ASSERT_FALSE(w.overrun);
  }
  EXPECT_EQ(s.overruns(), 0u);
  EXPECT_EQ(s.missed_periods(), 0u);
}

TEST(PeriodicSchedule, LateWakeWithinAPeriodIsLatencyNotOverrun) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  s.start();
  clock.stall_next_sleep(700us);
  const auto w = s.wait_next();
  EXPECT_EQ(w.latency, Nanos{700us});
  EXPECT_FALSE(w.overrun);
  EXPECT_EQ(w.missed, 0u);
  const auto w2 = s.wait_next();  // the next deadline is unchanged
  EXPECT_EQ(w2.deadline, Nanos{2ms});
  EXPECT_EQ(w2.latency, Nanos{0});
}

TEST(PeriodicSchedule, StallRunsOneLateCycleThenSkipsToTheNextFutureDeadline) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  s.start();
  s.wait_next();                     // deadline 1 ms
  clock.stall_next_sleep(43'500us);  // like the host stalling the vCPU
  const auto late = s.wait_next();   // deadline 2 ms, woke at 45.5 ms
  EXPECT_EQ(late.deadline, Nanos{2ms});
  EXPECT_EQ(late.woke, Nanos{45'500us});
  EXPECT_TRUE(late.overrun);
  EXPECT_EQ(late.missed, 43u);  // deadlines 3..45 ms are skipped
  EXPECT_EQ(s.next_index(), 46u);

  // No burst: the next cycle waits for the 46 ms deadline.
  const auto next = s.wait_next();
  EXPECT_EQ(next.deadline, Nanos{46ms});
  EXPECT_EQ(next.woke, Nanos{46ms});
  EXPECT_FALSE(next.overrun);
  EXPECT_EQ(s.overruns(), 1u);
  EXPECT_EQ(s.missed_periods(), 43u);
  EXPECT_EQ(s.cycles(), 3u);
}

TEST(PeriodicSchedule, ComputeLongerThanAPeriodCountsAsOverrun) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 500us);
  s.start();
  s.wait_next();                 // deadline 0.5 ms
  clock.advance(1'200us);        // cycle computes until 1.7 ms: 1.0 ms deadline passed
  const auto w = s.wait_next();  // sleeps to 1.0 ms: returns at once at 1.7 ms
  EXPECT_EQ(w.deadline, Nanos{1ms});
  EXPECT_EQ(w.latency, Nanos{700us});
  EXPECT_TRUE(w.overrun);
  EXPECT_EQ(w.missed, 1u);  // 1.5 ms skipped
  EXPECT_EQ(s.wait_next().deadline, Nanos{2ms});
}

// Minutes of simulated time with periodic stalls, in milliseconds of real
// time: the bookkeeping identity holds: every deadline up to the last one was
// either served by a cycle or counted as missed.
TEST(PeriodicSchedule, TenSimulatedMinutesWithStallsKeepTheBooks) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  s.start();
  std::uint64_t expected_overruns = 0;
  std::uint64_t expected_missed = 0;
  for (std::uint64_t i = 1; i <= 600'000; ++i) {
    if (i % 500 == 0) {  // twice a second, 1-43 ms stall
      const auto stall = Nanos{static_cast<std::int64_t>(1 + i % 43) * 1'000'000 + 250'000};
      clock.stall_next_sleep(stall);
      ++expected_overruns;
      expected_missed += static_cast<std::uint64_t>(stall / Nanos{1ms});
    }
    clock.advance(200us);
    const auto w = s.wait_next();
    ASSERT_GE(w.latency, Nanos{0});
    ASSERT_LT(w.woke, s.deadline_of(s.next_index()));  // next deadline is in the future
  }
  EXPECT_EQ(s.cycles(), 600'000u);
  EXPECT_EQ(s.overruns(), expected_overruns);
  EXPECT_EQ(s.missed_periods(), expected_missed);
  EXPECT_EQ(s.next_index() - 1, s.cycles() + s.missed_periods());
  EXPECT_GE(clock.now(), Nanos{600s});
}

// Real clock: a few hundred 1 ms periods complete, and the books balance.
// No latency assertion: this VM stalls for tens of ms at random.
TEST(PeriodicSchedule, RealClockRunsThreeHundredPeriods) {
  RealClock clock;
  PeriodicSchedule s(clock, 1ms);
  s.start();
  const auto t0 = clock.now();
  std::uint64_t cycles = 0;
  while (s.next_index() <= 300) {
    const auto w = s.wait_next();
    ASSERT_GE(w.woke, w.deadline);
    ++cycles;
  }
  const auto elapsed = clock.now() - t0;
  EXPECT_EQ(s.cycles(), cycles);
  EXPECT_EQ(s.next_index() - 1, s.cycles() + s.missed_periods());
  EXPECT_GE(s.next_index() - 1, 300u);
  EXPECT_GE(elapsed, Nanos{300ms});  // deadlines are never served early
}

}  // namespace loop_timing_test
