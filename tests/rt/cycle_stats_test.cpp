#include "rt/cycle_stats.hpp"

#include <gtest/gtest.h>

#include "rt/loop_timing.hpp"

namespace cycle_stats_test {

using hapticd::rt::CycleStats;
using hapticd::rt::Nanos;
using hapticd::rt::PeriodicSchedule;
using hapticd::rt::VirtualClock;
using namespace std::chrono_literals;

TEST(CycleStats, CountsOverrunsMissedPeriodsAndStreaks) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  CycleStats stats;
  s.start();
  // cycles 1..10 normal, 11..13 overrun (streak 3), 14 normal, 15 overrun.
  for (int i = 1; i <= 15; ++i) {
    if ((i >= 11 && i <= 13) || i == 15) clock.stall_next_sleep(2'500us);
    clock.advance(100us);
    const auto w = s.wait_next();
    stats.record(w, 100us);
    if (i == 13) {
      EXPECT_EQ(stats.overrun_streak(), 3u);
    }
  }
  const auto snap = stats.snapshot();
  EXPECT_EQ(snap.cycles, 15u);
  EXPECT_EQ(snap.overruns, 4u);
  EXPECT_EQ(snap.missed_periods, 8u);  // 2 per 2.5 ms stall
  EXPECT_EQ(snap.overrun_streak, 1u);
  EXPECT_EQ(snap.max_overrun_streak, 3u);
  EXPECT_EQ(snap.latency.count, 15u);
  EXPECT_EQ(snap.latency.max_ns, 2'500'000);
  EXPECT_EQ(snap.compute.percentile(0.5), Nanos{100us});
  EXPECT_EQ(snap.missed_periods, s.missed_periods());
}

// stats.reset: a fresh start for the statistics, but the current overrun
// streak (the safety rule's state) goes on.
TEST(CycleStats, ResetClearsTheStatisticsButKeepsTheCurrentStreak) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  CycleStats stats;
  s.start();
  for (int i = 1; i <= 10; ++i) {
    if (i >= 9) clock.stall_next_sleep(2'500us);  // cycles 9 and 10 overrun: streak 2
    stats.record(s.wait_next(), 300us);
  }
  stats.reset();
  auto snap = stats.snapshot();
  EXPECT_EQ(snap.cycles, 0u);
  EXPECT_EQ(snap.overruns, 0u);
  EXPECT_EQ(snap.missed_periods, 0u);
  EXPECT_EQ(snap.latency.count, 0u);
  EXPECT_EQ(snap.compute.count, 0u);
  EXPECT_EQ(snap.overrun_streak, 2u);
  EXPECT_EQ(snap.max_overrun_streak, 2u);
  // The next overrun extends that streak; counting starts afresh.
  clock.stall_next_sleep(2'500us);
  stats.record(s.wait_next(), 100us);
  snap = stats.snapshot();
  EXPECT_EQ(snap.cycles, 1u);
  EXPECT_EQ(snap.overruns, 1u);
  EXPECT_EQ(snap.overrun_streak, 3u);
  EXPECT_EQ(snap.max_overrun_streak, 3u);
  EXPECT_EQ(snap.compute.max_ns, 100'000);
}

}  // namespace cycle_stats_test
