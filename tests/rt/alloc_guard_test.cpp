#include "tests/support/alloc_counter.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <thread>
#include <vector>

#include "rt/cycle_stats.hpp"
#include "rt/loop_timing.hpp"
#include "rt/mailbox.hpp"
#include "rt/spsc_ring.hpp"

namespace alloc_guard_test {

using hapticd::testing::AllocationGuard;
using namespace hapticd::rt;
using namespace std::chrono_literals;

namespace {
// Keeps the compiler from eliding a new/delete pair.
template <class P>
void escape(P p) {
  asm volatile("" : : "g"(p) : "memory");
}
}  // namespace

TEST(AllocationGuard, CountsADeliberateNew) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  std::size_t n = 0, freed = 0;
  {
    AllocationGuard g;
    auto* p = new int(3);
    escape(p);
    delete p;
    auto v = std::make_unique<std::vector<double>>(100);
    escape(v.get());
    v.reset();
    n = g.count();
    freed = g.deallocations();
  }
  EXPECT_EQ(n, 3u);  // int, vector object, vector buffer
  EXPECT_EQ(freed, 3u);
}

TEST(AllocationGuard, IgnoresOtherThreadsAndNests) {
  AllocationGuard outer;
  std::thread([] {
    for (int i = 0; i < 10; ++i) escape(std::make_unique<int>(i).get());
  }).join();
  // std::thread's own state is allocated on this thread: measure from here.
  const std::size_t before = outer.count();
  {
    AllocationGuard inner;
    escape(std::make_unique<int>(1).get());
    EXPECT_EQ(inner.count(), 1u);
  }
  escape(std::make_unique<int>(2).get());
  EXPECT_EQ(outer.count() - before, 2u);
}

TEST(AllocationGuard, RingPushPopAllocatesNothing) {
  SpscRing<double> ring(256);
  std::size_t n = 1;
  {
    AllocationGuard g;
    for (int i = 0; i < 100'000; ++i) {
      ring.try_push(i);
      double v;
      ring.try_pop(v);
      escape(&v);
    }
    std::array<double, 16> out{};
    for (int i = 0; i < 300; ++i) ring.try_push(i);  // includes drops
    ring.pop_bulk(out);
    n = g.count();
  }
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(ring.dropped(), 300u - 256u);
}

TEST(AllocationGuard, MailboxAcquireAllocatesNothingEvenWhenHandingOver) {
  Mailbox<std::vector<double>> box;
  std::size_t n = 1;
  std::uint64_t cycle = 0;
  for (int round = 0; round < 100; ++round) {
    box.publish(std::make_unique<std::vector<double>>(64, round));  // writer side: allocates
    AllocationGuard g;
    for (int i = 0; i < 100; ++i) escape(box.acquire(++cycle));  // first one hands over + retires
    n = g.count() + g.deallocations();
    if (n != 0) break;
  }
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(box.applied().seq, 100u);
}

TEST(AllocationGuard, ScheduleAndStatsAllocateNothing) {
  VirtualClock clock;
  PeriodicSchedule s(clock, 1ms);
  auto stats = std::make_unique<CycleStats>();
  s.start();
  std::size_t n = 1;
  {
    AllocationGuard g;
    for (int i = 0; i < 100'000; ++i) {
      if (i % 1000 == 0) clock.stall_next_sleep(5ms);
      const auto w = s.wait_next();
      stats->record(w, 30us);
    }
    n = g.count();
  }
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(stats->snapshot().cycles, 100'000u);
}

}  // namespace alloc_guard_test
