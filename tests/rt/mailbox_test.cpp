#include "rt/mailbox.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

namespace mailbox_test {

using hapticd::rt::Mailbox;
using namespace std::chrono_literals;

namespace {

// Counts live instances so the tests see who deleted what, and when.
struct Plan {
  static inline std::atomic<int> live{0};
  explicit Plan(int v) : value(v), check(~v) { ++live; }
  ~Plan() { --live; }
  Plan(const Plan&) = delete;
  int value;
  int check;  // ~value: a torn or freed object would not satisfy it
};

}  // namespace

TEST(Mailbox, NothingBeforeTheFirstPublication) {
  Mailbox<Plan> box;
  EXPECT_EQ(box.acquire(1), nullptr);
  EXPECT_EQ(box.applied().seq, 0u);
  EXPECT_THROW(box.publish(nullptr), std::invalid_argument);
}

TEST(Mailbox, HandOverTakesEffectAtTheNextAcquireAndRecordsTheCycle) {
  Plan::live = 0;
  {
    Mailbox<Plan> box;
    const auto p1 = box.publish(std::make_unique<Plan>(1));
    EXPECT_EQ(p1.seq, 1u);
    EXPECT_EQ(p1.superseded_seq, 0u);
    EXPECT_EQ(box.applied().seq, 0u);  // not yet: the RT thread has not acquired

    const Plan* cur = box.acquire(41);
    ASSERT_NE(cur, nullptr);
    EXPECT_EQ(cur->value, 1);
    EXPECT_EQ(box.applied().seq, 1u);
    EXPECT_EQ(box.applied().cycle, 41u);

    EXPECT_EQ(box.acquire(42), cur);  // nothing new: same object, cycle unchanged
    EXPECT_EQ(box.applied().cycle, 41u);

    box.publish(std::make_unique<Plan>(2));
    EXPECT_EQ(box.acquire(50)->value, 2);
    EXPECT_EQ(box.applied().seq, 2u);
    EXPECT_EQ(box.applied().cycle, 50u);
    EXPECT_EQ(Plan::live, 2);  // plan 1 retired but not freed by the RT side
    EXPECT_EQ(box.collect(), 1u);
    EXPECT_EQ(Plan::live, 1);
    EXPECT_EQ(box.retire_failures(), 0u);
  }
  EXPECT_EQ(Plan::live, 0);  // destructor frees the current one
}

TEST(Mailbox, NewerPublicationSupersedesAnUnseenOne) {
  Plan::live = 0;
  Mailbox<Plan> box;
  box.publish(std::make_unique<Plan>(1));
  const auto p2 = box.publish(std::make_unique<Plan>(2));
  EXPECT_EQ(p2.superseded_seq, 1u);
  EXPECT_EQ(Plan::live, 1);  // the writer deleted plan 1 itself
  EXPECT_EQ(box.acquire(7)->value, 2);
  EXPECT_EQ(box.applied().seq, 2u);
}

TEST(Mailbox, DestructorFreesPendingAndRetiredObjects) {
  Plan::live = 0;
  {
    Mailbox<Plan> box;
    box.publish(std::make_unique<Plan>(1));
    box.acquire(1);
    box.publish(std::make_unique<Plan>(2));
    box.acquire(2);                          // plan 1 now retired, uncollected
    box.publish(std::make_unique<Plan>(3));  // collects plan 1; plan 3 pending
    EXPECT_EQ(Plan::live, 2);
  }
  EXPECT_EQ(Plan::live, 0);
}

TEST(Mailbox, WaitAppliedReportsTheCycleOrTimesOut) {
  Mailbox<Plan> box;
  const auto p = box.publish(std::make_unique<Plan>(5));
  EXPECT_FALSE(box.wait_applied(p.seq, 2ms).has_value());
  std::thread rt([&] {
    std::this_thread::sleep_for(5ms);
    box.acquire(1234);
  });
  const auto a = box.wait_applied(p.seq, 10s);
  rt.join();
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->seq, p.seq);
  EXPECT_EQ(a->cycle, 1234u);
}

// An RT-like thread acquires every "cycle" and checks the object it holds is
// intact and never goes backwards, while the writer publishes and collects as
// fast as it can. Run under TSan by tests/run_sanitizers.sh (tsan).
TEST(Mailbox, ConcurrentPublishAcquireStress) {
  Plan::live = 0;
  constexpr int publications = 20000;
  {
    Mailbox<Plan> box;
    std::atomic<bool> stop{false};
    std::atomic<bool> bad{false};
    std::atomic<std::uint64_t> rt_cycles{0};
    std::thread rt([&] {
      std::uint64_t cycle = 0;
      int last = 0;
      while (!stop.load(std::memory_order_acquire)) {
        const Plan* p = box.acquire(++cycle);
        if (p) {
          if (p->check != ~p->value || p->value < last) bad = true;
          last = p->value;
        }
      }
      rt_cycles = cycle;
    });
    std::uint64_t superseded = 0;
    std::uint64_t last_cycle = 0;
    for (int i = 1; i <= publications; ++i) {
      const auto pub = box.publish(std::make_unique<Plan>(i));
      if (pub.superseded_seq) ++superseded;
      const auto a = box.applied();
      if (a.cycle < last_cycle) bad = true;  // effective cycles never go backwards
      last_cycle = a.cycle;
      EXPECT_LE(Plan::live, 4);  // current + pending + at most 2 retired: bounded
    }
    const auto final_applied = box.wait_applied(publications, 30s);
    stop = true;
    rt.join();
    ASSERT_TRUE(final_applied.has_value());
    EXPECT_EQ(final_applied->seq, static_cast<std::uint64_t>(publications));
    EXPECT_FALSE(bad.load());
    EXPECT_EQ(box.retire_failures(), 0u);
    EXPECT_GT(rt_cycles.load(), 0u);
    RecordProperty("superseded", static_cast<int>(superseded));
  }
  EXPECT_EQ(Plan::live, 0);
}

}  // namespace mailbox_test
