#include "rt/latency_stats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hapticd::rt {

HistogramLayout::HistogramLayout() noexcept {
  for (std::size_t k = 0; k <= log_buckets; ++k) {
    const double e = static_cast<double>(linear_limit_ns) *
                     std::exp2(static_cast<double>(k) / static_cast<double>(log_per_octave));
    log_edges_[k] = std::min(static_cast<std::int64_t>(std::llround(e)), log_limit_ns);
  }
  log_edges_[log_buckets] = log_limit_ns;
}

std::size_t HistogramLayout::index_of(std::int64_t ns) const noexcept {
  if (ns < 0) ns = 0;
  if (ns < linear_limit_ns) return static_cast<std::size_t>(ns / linear_width_ns);
  if (ns >= log_limit_ns) return overflow_bucket;
  // First edge > ns, minus one, is the bucket among the log ones.
  const auto it = std::upper_bound(log_edges_.begin(), log_edges_.end(), ns);
  return linear_buckets + static_cast<std::size_t>(it - log_edges_.begin()) - 1;
}

std::int64_t HistogramLayout::lower(std::size_t b) const noexcept {
  if (b < linear_buckets) return static_cast<std::int64_t>(b) * linear_width_ns;
  if (b >= overflow_bucket) return log_limit_ns;
  return log_edges_[b - linear_buckets];
}

std::int64_t HistogramLayout::upper(std::size_t b) const noexcept {
  if (b < linear_buckets) return static_cast<std::int64_t>(b + 1) * linear_width_ns;
  if (b >= overflow_bucket) return std::numeric_limits<std::int64_t>::max();
  return log_edges_[b - linear_buckets + 1];
}

Nanos HistogramSnapshot::percentile(double p) const noexcept {
  if (count == 0) return Nanos{0};
  p = std::clamp(p, 0.0, 1.0);
  auto rank = static_cast<std::uint64_t>(std::ceil(p * static_cast<double>(count)));
  rank = std::max<std::uint64_t>(rank, 1);
  std::uint64_t cumulative = 0;
  for (std::size_t b = 0; b < counts.size(); ++b) {
    cumulative += counts[b];
    if (cumulative >= rank) {
      const std::int64_t v = std::min(layout.upper(b), max_ns);
      return Nanos{std::max(v, min_ns)};
    }
  }
  return Nanos{max_ns};
}

HistogramSnapshot LatencyHistogram::snapshot() const {
  HistogramSnapshot s;
  s.counts.resize(HistogramLayout::bucket_count);
  s.consistent = version_.read([&] {
    for (std::size_t b = 0; b < buckets_.size(); ++b) s.counts[b] = seq_load(buckets_[b]);
    s.count = seq_load(count_);
    s.min_ns = seq_load(min_);
    s.max_ns = seq_load(max_);
    s.sum_ns = seq_load(sum_);
  });
  return s;
}

void LatencyHistogram::reset() noexcept {
  version_.write_begin();
  for (auto& b : buckets_) seq_store(b, 0);
  seq_store(count_, 0);
  seq_store(min_, 0);
  seq_store(max_, 0);
  seq_store(sum_, 0);
  version_.write_end();
}

}  // namespace hapticd::rt
