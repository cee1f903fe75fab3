#include "rt/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <thread>
#include <vector>

namespace spsc_ring_test {

using hapticd::rt::SpscRing;

TEST(SpscRing, RejectsCapacityThatIsNotAPowerOfTwo) {
  EXPECT_THROW(SpscRing<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(1), std::invalid_argument);
  EXPECT_THROW(SpscRing<int>(6), std::invalid_argument);
  EXPECT_NO_THROW(SpscRing<int>(8));
}

TEST(SpscRing, EmptyPopFailsAndFullPushIsCountedAsDrop) {
  SpscRing<int> ring(4);
  int v = -1;
  EXPECT_FALSE(ring.try_pop(v));
  EXPECT_TRUE(ring.empty());
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(ring.try_push(i));
  EXPECT_EQ(ring.size(), 4u);
  EXPECT_FALSE(ring.try_push(99));
  EXPECT_FALSE(ring.try_push(100));
  EXPECT_EQ(ring.dropped(), 2u);
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.try_pop(v));
    EXPECT_EQ(v, i);  // the dropped 99/100 never appear
  }
  EXPECT_FALSE(ring.try_pop(v));
}

TEST(SpscRing, WrapsAroundManyTimesInOrder) {
  SpscRing<std::uint64_t> ring(8);
  std::uint64_t next_in = 0, next_out = 0;
  for (int round = 0; round < 1000; ++round) {
    const int n = 1 + round % 8;
    for (int i = 0; i < n; ++i) ASSERT_TRUE(ring.try_push(next_in++));
    for (int i = 0; i < n; ++i) {
      std::uint64_t v = 0;
      ASSERT_TRUE(ring.try_pop(v));
      ASSERT_EQ(v, next_out++);
    }
  }
  EXPECT_EQ(ring.dropped(), 0u);
}

TEST(SpscRing, PopBulkTakesWhatIsThereUpToTheSpan) {
  SpscRing<int> ring(8);
  for (int i = 0; i < 6; ++i) ring.try_push(i);
  std::array<int, 4> out{};
  EXPECT_EQ(ring.pop_bulk(out), 4u);
  EXPECT_EQ(out, (std::array<int, 4>{0, 1, 2, 3}));
  for (int i = 6; i < 10; ++i) ring.try_push(i);  // wraps the buffer
  std::array<int, 8> rest{};
  EXPECT_EQ(ring.pop_bulk(rest), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(rest[static_cast<std::size_t>(i)], 4 + i);
  EXPECT_EQ(ring.pop_bulk(rest), 0u);
}

struct Sample {
  std::uint64_t seq;
  double payload[3];
};

// Producer and consumer on two threads: 10 million items arrive complete and
// in order (the producer retries on full, so nothing is dropped by design,
// but every refused push is still counted).
TEST(SpscRing, ConcurrentTransferOfTenMillionItemsInOrder) {
  constexpr std::uint64_t total = 10'000'000;
  SpscRing<Sample> ring(1024);
  std::uint64_t refused = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < total; ++i) {
      const Sample s{i, {static_cast<double>(i), -static_cast<double>(i), 0.5}};
      while (!ring.try_push(s)) ++refused;
    }
  });
  std::uint64_t expected = 0;
  bool ok = true;
  std::array<Sample, 64> batch{};
  while (expected < total && ok) {
    const std::size_t n = (expected % 3 == 0) ? ring.pop_bulk(batch) : (ring.try_pop(batch[0]) ? 1u : 0u);
    for (std::size_t i = 0; i < n; ++i) {
      const Sample& s = batch[i];
      if (s.seq != expected || s.payload[0] != static_cast<double>(expected) ||
          s.payload[1] != -static_cast<double>(expected)) {
        ok = false;
        break;
      }
      ++expected;
    }
  }
  producer.join();
  EXPECT_TRUE(ok) << "out of order or torn at item " << expected;
  EXPECT_EQ(expected, total);
  EXPECT_EQ(ring.dropped(), refused);
  EXPECT_TRUE(ring.empty());
}

}  // namespace spsc_ring_test
