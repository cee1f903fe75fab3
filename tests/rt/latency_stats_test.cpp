#include "rt/latency_stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>
#include <thread>
#include <vector>

namespace latency_stats_test {

using hapticd::rt::HistogramLayout;
using hapticd::rt::LatencyHistogram;
using hapticd::rt::Nanos;

TEST(HistogramLayout, BucketsAreContiguousAndCoverEverything) {
  HistogramLayout l;
  EXPECT_EQ(l.index_of(-5), 0u);
  EXPECT_EQ(l.index_of(0), 0u);
  EXPECT_EQ(l.index_of(999), 0u);
  EXPECT_EQ(l.index_of(1000), 1u);
  EXPECT_EQ(l.index_of(1'999'999), 1999u);
  EXPECT_EQ(l.index_of(2'000'000), HistogramLayout::linear_buckets);
  EXPECT_EQ(l.index_of(99'999'999), HistogramLayout::overflow_bucket - 1);
  EXPECT_EQ(l.index_of(100'000'000), HistogramLayout::overflow_bucket);
  for (std::size_t b = 0; b + 1 < HistogramLayout::bucket_count; ++b) {
    ASSERT_LT(l.lower(b), l.upper(b)) << b;
    ASSERT_EQ(l.upper(b), l.lower(b + 1)) << b;
    ASSERT_EQ(l.index_of(l.lower(b)), b);
    ASSERT_EQ(l.index_of(l.upper(b) - 1), b);
  }
  // Log region: about 8 buckets per octave (ratio 2^(1/8) = 1.09).
  const std::size_t b = l.index_of(10'000'000);
  EXPECT_NEAR(static_cast<double>(l.upper(b)) / static_cast<double>(l.lower(b)), std::exp2(1.0 / 8), 1e-3);
}

namespace {

std::int64_t reference_percentile(std::vector<std::int64_t> sorted, double p) {
  const auto n = sorted.size();
  auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(n)));
  rank = std::max<std::size_t>(rank, 1);
  return sorted[rank - 1];
}

}  // namespace

// Wake-up-latency-like data: a bulk around 50 us, a tail to a few ms and rare
// stalls of tens of ms. Each histogram percentile is >= the exact nearest-rank
// value and within one bucket width of it.
TEST(LatencyHistogram, PercentilesMatchASortedReferenceWithinABucket) {
  std::mt19937_64 rng(42);
  std::lognormal_distribution<double> bulk(std::log(50'000.0), 0.6);
  std::uniform_real_distribution<double> stall(1e6, 43e6);
  std::uniform_real_distribution<double> u(0, 1);
  LatencyHistogram h;
  std::vector<std::int64_t> values;
  for (int i = 0; i < 200'000; ++i) {
    const double v = u(rng) < 0.002 ? stall(rng) : bulk(rng);
    const auto ns = static_cast<std::int64_t>(v);
    values.push_back(ns);
    h.record(Nanos{ns});
  }
  values.push_back(250'000'000);  // one overflow
  h.record(Nanos{250'000'000});
  std::sort(values.begin(), values.end());
  const auto s = h.snapshot();
  ASSERT_TRUE(s.consistent);
  EXPECT_EQ(s.count, values.size());
  EXPECT_EQ(s.min_ns, values.front());
  EXPECT_EQ(s.max_ns, values.back());
  for (double p : {0.0, 0.01, 0.5, 0.9, 0.99, 0.998, 0.999, 0.9999, 1.0}) {
    const std::int64_t ref = reference_percentile(values, p);
    const std::int64_t got = s.percentile(p).count();
    const std::size_t b = s.layout.index_of(ref);
    const std::int64_t width =
        b == HistogramLayout::overflow_bucket ? 0 : s.layout.upper(b) - s.layout.lower(b);
    EXPECT_GE(got, ref) << "p=" << p;
    EXPECT_LE(got - ref, width) << "p=" << p;
  }
  EXPECT_EQ(s.percentile(1.0).count(), 250'000'000);
  std::int64_t sum = 0;
  for (auto v : values) sum += v;
  EXPECT_EQ(s.sum_ns, sum);
}

TEST(LatencyHistogram, EmptyAndResetReportZero) {
  LatencyHistogram h;
  EXPECT_EQ(h.snapshot().percentile(0.99), Nanos{0});
  h.record(Nanos{12'345});
  EXPECT_EQ(h.snapshot().percentile(0.5), Nanos{12'345});  // clipped to max
  h.reset();
  const auto s = h.snapshot();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.max_ns, 0);
}

// A reader taking snapshots while the writer records never sees a torn
// state: the bucket counts always add up to `count`, and it never decreases.
TEST(LatencyHistogram, SnapshotsAreConsistentWhileTheWriterRuns) {
  LatencyHistogram h;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::int64_t i = 0; i < 2'000'000; ++i) h.record(Nanos{(i * 7919) % 3'000'000});
    done = true;
  });
  std::uint64_t last = 0;
  int snapshots = 0;
  bool ok = true;
  while (!done.load() || snapshots < 10) {
    const auto s = h.snapshot();
    if (!s.consistent) continue;
    std::uint64_t total = 0;
    for (auto c : s.counts) total += c;
    if (total != s.count || s.count < last) ok = false;
    last = s.count;
    ++snapshots;
  }
  writer.join();
  EXPECT_TRUE(ok);
  EXPECT_EQ(h.snapshot().count, 2'000'000u);
}

}  // namespace latency_stats_test
