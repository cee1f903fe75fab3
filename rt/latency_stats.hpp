#pragma once
/// \file
/// Fixed-bucket latency histogram for wake-up latency and per-cycle compute
/// time. Why this shape:
/// - all storage is a member std::array: nothing is allocated, ever, so the
///   RT thread can record into it every period;
/// - 1 us buckets up to 2 ms (where the interesting distribution lives; the
///   same resolution as cyclictest's histogram, so the two compare directly),
///   then 8 log buckets per octave up to 100 ms (host stalls of 1-43 ms are
///   seen here), then one overflow bucket; exact min/max/sum on the side;
/// - one writer (the RT thread) bumps single-writer atomics inside a seqlock; a
///   non-RT reader takes a consistent snapshot without ever blocking it;
/// - percentiles are computed outside RT, from the snapshot.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "rt/clock.hpp"
#include "rt/seqlock.hpp"

namespace hapticd::rt {

/// Bucket boundaries, shared by the histogram and its snapshots.
class HistogramLayout {
 public:
  static constexpr std::int64_t linear_width_ns = 1'000;      // 1 us
  static constexpr std::int64_t linear_limit_ns = 2'000'000;  // 2 ms
  static constexpr std::int64_t log_limit_ns = 100'000'000;   // 100 ms
  static constexpr std::size_t log_per_octave = 8;
  static constexpr std::size_t linear_buckets = linear_limit_ns / linear_width_ns;  // 2000
  static constexpr std::size_t log_buckets = 46;  // 2 ms * 2^(46/8) > 100 ms; last edge clamped
  static constexpr std::size_t overflow_bucket = linear_buckets + log_buckets;
  static constexpr std::size_t bucket_count = overflow_bucket + 1;

  HistogramLayout() noexcept;
  /// Bucket of a value in ns (negative values count as 0). No allocation.
  std::size_t index_of(std::int64_t ns) const noexcept;
  /// [lower, upper) of a bucket in ns; the overflow bucket's upper is INT64_MAX.
  std::int64_t lower(std::size_t bucket) const noexcept;
  std::int64_t upper(std::size_t bucket) const noexcept;

 private:
  std::array<std::int64_t, log_buckets + 1> log_edges_{};  // log_edges_[0] = 2 ms, [46] = 100 ms
};

/// A copy of the histogram, taken outside RT. Allocates.
struct HistogramSnapshot {
  std::vector<std::uint64_t> counts;  ///< HistogramLayout::bucket_count entries
  std::uint64_t count = 0;
  std::int64_t min_ns = 0;
  std::int64_t max_ns = 0;
  std::int64_t sum_ns = 0;
  bool consistent = true;  ///< false only if the reader gave up retrying
  HistogramLayout layout;

  /// Nearest-rank percentile, p in [0, 1]: the upper edge of the bucket that
  /// holds the rank, clipped to [min, max]. Never below the true value, at
  /// most one bucket width above it. 0 when empty.
  Nanos percentile(double p) const noexcept;
  Nanos mean() const noexcept { return Nanos{count ? sum_ns / static_cast<std::int64_t>(count) : 0}; }
};

class LatencyHistogram {
 public:
  LatencyHistogram() noexcept = default;
  LatencyHistogram(const LatencyHistogram&) = delete;
  LatencyHistogram& operator=(const LatencyHistogram&) = delete;

  /// Single writer (the RT thread). Allocation-free, wait-free.
  void record(Nanos value) noexcept {
    const std::int64_t ns = value.count() < 0 ? 0 : value.count();
    const std::size_t b = layout_.index_of(ns);
    version_.write_begin();
    single_writer_add(buckets_[b], std::uint64_t{1});
    const std::uint64_t n = count_.load(std::memory_order_relaxed);
    if (n == 0 || ns < min_.load(std::memory_order_relaxed)) seq_store(min_, ns);
    if (n == 0 || ns > max_.load(std::memory_order_relaxed)) seq_store(max_, ns);
    single_writer_add(sum_, ns);
    seq_store(count_, n + 1);
    version_.write_end();
  }

  /// Any thread; never blocks the writer. Allocates.
  HistogramSnapshot snapshot() const;

  /// Single writer: clear (e.g. after a scene change). Allocation-free.
  void reset() noexcept;

  const HistogramLayout& layout() const noexcept { return layout_; }

 private:
  HistogramLayout layout_;
  SeqlockVersion version_;
  std::array<std::atomic<std::uint64_t>, HistogramLayout::bucket_count> buckets_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> min_{0};
  std::atomic<std::int64_t> max_{0};
  std::atomic<std::int64_t> sum_{0};
};

}  // namespace hapticd::rt
