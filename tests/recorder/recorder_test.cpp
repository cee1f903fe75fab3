#include "daemon/recorder/recorder.hpp"

#include <sched.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace hapticd::daemon::recorder::recorder_test {
namespace {

using namespace std::chrono_literals;

/// TEST ONLY: a bounded mutex-protected queue standing in for the RT ring.
/// push() never waits for the consumer: when full it fails and counts, like
/// the RT side does.
class TestRing {
 public:
  explicit TestRing(std::size_t capacity) : capacity_(capacity) {}
  bool push(const TelemetrySample& sample) {
    std::lock_guard lock(mutex_);
    if (queue_.size() >= capacity_) {
      drops_.fetch_add(1);
      return false;
    }
    queue_.push_back(sample);
    return true;
  }
  std::size_t pop(std::span<TelemetrySample> out) {
    std::lock_guard lock(mutex_);
    std::size_t n = 0;
    while (n < out.size() && !queue_.empty()) {
      out[n++] = queue_.front();
      queue_.pop_front();
    }
    return n;
  }
  std::uint64_t drops() const { return drops_.load(); }
  std::size_t size() {
    std::lock_guard lock(mutex_);
    return queue_.size();
  }

 private:
  std::size_t capacity_;
  std::mutex mutex_;
  std::deque<TelemetrySample> queue_;
  std::atomic<std::uint64_t> drops_{0};
};

/// In-memory sink; can stall every write for a while, fail, or be a disk
/// of `capacity` bytes.
struct MemoryData {
  std::mutex mutex;
  std::string bytes;
  int syncs = 0;
  int truncations = 0;
  bool closed = false;
  std::chrono::milliseconds stall{0};
  bool fail = false;
  std::size_t capacity = std::string::npos;
  std::string contents() {
    std::lock_guard lock(mutex);
    return bytes;
  }
  void set_capacity(std::size_t bytes_available) {
    std::lock_guard lock(mutex);
    capacity = bytes_available;
  }
};

class MemorySink final : public Sink {
 public:
  explicit MemorySink(std::shared_ptr<MemoryData> data) : data_(std::move(data)) {}
  void write(std::string_view bytes) override {
    std::chrono::milliseconds stall{};
    {
      std::lock_guard lock(data_->mutex);
      stall = data_->stall;
      if (data_->fail) throw RecorderError("write test: No space left on device");
    }
    if (stall.count() > 0) std::this_thread::sleep_for(stall);
    std::lock_guard lock(data_->mutex);
    // Like write(2) on a full disk: what fits goes in, then ENOSPC.
    const std::size_t room = data_->capacity - std::min(data_->capacity, data_->bytes.size());
    data_->bytes.append(bytes.substr(0, room));
    if (bytes.size() > room) {
      throw SinkWriteError("write test: No space left on device", ENOSPC, room);
    }
  }
  void truncate(std::uint64_t size) override {
    std::lock_guard lock(data_->mutex);
    data_->bytes.resize(static_cast<std::size_t>(size));
    ++data_->truncations;
  }
  void sync() override {
    std::lock_guard lock(data_->mutex);
    ++data_->syncs;
  }
  void close() override {
    std::lock_guard lock(data_->mutex);
    data_->closed = true;
  }

 private:
  std::shared_ptr<MemoryData> data_;
};

SinkFactory memory_factory(std::shared_ptr<MemoryData> data) {
  return [data](const std::filesystem::path&) { return std::make_unique<MemorySink>(data); };
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("hapticd-recorder-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

RecordingHeader wheel_header() {
  RecordingHeader h;
  h.scene = "spring-wheel";
  h.parameters = {{"stiffness", "1.0186 N m/rad"}, {"integrator", "exact"}};
  h.channels = {{"velocity", "rad/s"}, {"virtual_position", "rad"}};
  h.rotary = true;
  h.period_s = 1e-3;
  h.clock = "virtual";
  h.device = "loopback (rotary, rigid)";
  return h;
}

RecordingHeader wall_header() {
  RecordingHeader h;
  h.scene = "wall";
  h.parameters = {{"stiffness", "9000 N/m"}};
  h.rotary = false;
  h.period_s = 1e-3;
  h.device = "loopback (linear, rigid)";
  return h;
}

TelemetrySample sample_for(std::uint64_t cycle, std::uint32_t channels = 2) {
  TelemetrySample s;
  s.cycle = cycle;
  s.time_s = static_cast<double>(cycle) * 1e-3;
  s.position = std::sin(static_cast<double>(cycle) * 1e-3);
  s.command = -0.5 * s.position;
  s.applied = s.command;
  s.latency_s = 1e-5 * static_cast<double>(cycle % 7);
  s.compute_s = 2e-6;
  s.flags = static_cast<std::uint32_t>(cycle % 3 == 0 ? 2 : 0);
  s.channel_count = channels;
  s.channels[0] = static_cast<double>(cycle) * 0.5;
  s.channels[1] = -static_cast<double>(cycle);
  return s;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  return fields;
}

template <class Pred>
bool wait_until(Pred pred, std::chrono::milliseconds timeout = 10s) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

TEST(RecorderColumns, UnitsInNamesOnlySceneChannels) {
  const auto wheel = column_names(wheel_header());
  std::string joined;
  for (const auto& n : wheel) joined += (joined.empty() ? "" : ",") + n;
  EXPECT_EQ(
      joined,
      "time_s,cycle,position_rad,velocity_rad_per_s,virtual_position_rad,command_n_m,applied_n_m,latency_s,"
      "compute_s,flags");
  const auto wall = column_names(wall_header());
  joined.clear();
  for (const auto& n : wall) joined += (joined.empty() ? "" : ",") + n;
  EXPECT_EQ(joined, "time_s,cycle,position_m,command_n,applied_n,latency_s,compute_s,flags");
  EXPECT_EQ(unit_suffix("rad/s"), "rad_per_s");
  EXPECT_EQ(unit_suffix("N m"), "n_m");
  EXPECT_EQ(unit_suffix("m/s^2"), "m_per_s2");
  EXPECT_EQ(unit_suffix("N m s/rad"), "n_m_s_per_rad");
  EXPECT_EQ(unit_suffix(""), "");
  RecordingHeader h = wall_header();
  h.channels = {{"contact", ""}, {"velocity_m_per_s", "m/s"}};
  const auto names = column_names(h);
  EXPECT_EQ(names[3], "contact");
  EXPECT_EQ(names[4], "velocity_m_per_s");  // no doubled suffix
}

TEST(Recorder, HeaderBlockAndFlushOnStop) {
  TestRing ring(1000);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("header");
  options.flush_interval_s = 10.0;  // only stop() may write the samples
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.set_ring_drop_counter([&] { return ring.drops(); });
  const auto path = recorder.start("run1", wheel_header());
  EXPECT_EQ(path, options.directory / "run1.csv");
  for (std::uint64_t c = 1; c <= 10; ++c) ASSERT_TRUE(ring.push(sample_for(c)));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_drained == 10; }));
  EXPECT_EQ(data->contents(), "");  // buffered: nothing reached the sink yet
  const RecorderStatus final = recorder.stop();
  EXPECT_FALSE(final.recording);
  EXPECT_EQ(final.samples_written, 10u);
  EXPECT_EQ(final.dropped_ring, 0u);
  EXPECT_EQ(final.dropped_write, 0u);
  EXPECT_EQ(data->syncs, 1);
  EXPECT_TRUE(data->closed);

  const auto lines = lines_of(data->contents());
  ASSERT_GE(lines.size(), 20u);
  EXPECT_EQ(lines[0], "# hapticd recording");
  EXPECT_TRUE(std::regex_match(lines[1], std::regex(R"(# hapticd_version: \d+\.\d+\.\d+)"))) << lines[1];
  const std::string text = data->contents();
  EXPECT_TRUE(std::regex_search(
      text, std::regex("\n# start_utc: \\d{4}-\\d\\d-\\d\\dT\\d\\d:\\d\\d:\\d\\d\\.\\d{9}Z\n")));
  EXPECT_TRUE(std::regex_search(text, std::regex("\n# start_clock_realtime_s: \\d{10,}\\.\\d{9}\n")));
  EXPECT_NE(text.find("\n# device: loopback (rotary, rigid)\n"), std::string::npos);
  EXPECT_NE(text.find("\n# motion: rotary\n"), std::string::npos);
  EXPECT_NE(text.find("\n# clock: virtual\n"), std::string::npos);
  EXPECT_NE(text.find("\n# period_s: 0.001\n"), std::string::npos);
  EXPECT_NE(text.find("\n# scene: spring-wheel\n"), std::string::npos);
  EXPECT_NE(text.find("\n# parameter stiffness: 1.0186 N m/rad\n# parameter integrator: exact\n"),
            std::string::npos);
  EXPECT_NE(
      text.find("\n# units: time_s s; cycle periods since loop start; position_rad rad; velocity_rad_per_s "
                "rad/s; virtual_position_rad rad; command_n_m N m (scene output before the limit); "
                "applied_n_m N m (sent to the device); latency_s s; compute_s s\n"),
      std::string::npos);
  // Column line, then the samples, then the trailer.
  std::size_t column_line = 0;
  while (column_line < lines.size() && lines[column_line].starts_with("#")) ++column_line;
  ASSERT_LT(column_line + 10, lines.size());
  EXPECT_EQ(
      lines[column_line],
      "time_s,cycle,position_rad,velocity_rad_per_s,virtual_position_rad,command_n_m,applied_n_m,latency_s,"
      "compute_s,flags");
  const auto first = split(lines[column_line + 1]);
  ASSERT_EQ(first.size(), 10u);
  EXPECT_EQ(first[0], "0.001");
  EXPECT_EQ(first[1], "1");
  EXPECT_EQ(std::stod(first[2]), sample_for(1).position);
  EXPECT_EQ(first[3], "0.5");
  EXPECT_EQ(first[4], "-1");
  EXPECT_EQ(first[9], "0");
  EXPECT_EQ(lines.back(), "# dropped 0 samples (ring full: 0, write failed: 0)");
  EXPECT_NE(text.find("\n# samples_written: 10\n"), std::string::npos);
}

TEST(Recorder, TenMinutesAt1kHzNoLossToARealFile) {
  constexpr std::uint64_t total = 600000;
  TestRing ring(1u << 18);
  RecorderOptions options;
  options.directory = temp_dir("ten-minutes");
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.set_ring_drop_counter([&] { return ring.drops(); });
  const auto path = recorder.start("ten-minutes.csv", wheel_header());

  // 200 samples per millisecond: 10 simulated minutes in about 3 s. The ring
  // holds over a second of that; the producer never waits for the recorder.
  std::thread producer([&] {
    auto next = std::chrono::steady_clock::now();
    for (std::uint64_t c = 1; c <= total; ++c) {
      ring.push(sample_for(c));
      if (c % 200 == 0) {
        next += 1ms;
        std::this_thread::sleep_until(next);
      }
    }
  });
  producer.join();
  ASSERT_TRUE(wait_until([&] { return ring.size() == 0; }, 60s));
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(ring.drops(), 0u);
  EXPECT_EQ(final.samples_written, total);
  EXPECT_EQ(final.dropped_ring, 0u);
  EXPECT_EQ(final.cycle_gaps, 0u);

  std::ifstream in(path);
  std::string line;
  std::uint64_t data_lines = 0;
  std::uint64_t expected_cycle = 1;
  std::string last_comment;
  bool values_ok = true;
  while (std::getline(in, line)) {
    if (line.starts_with("#")) {
      last_comment = line;
      continue;
    }
    if (line.starts_with("time_s,")) continue;
    ++data_lines;
    const auto f = split(line);
    const TelemetrySample s = sample_for(expected_cycle);
    // Shortest round-trip formatting: the parsed values are bit-identical.
    if (f.size() != 10 || std::stoull(f[1]) != expected_cycle || std::stod(f[0]) != s.time_s ||
        std::stod(f[2]) != s.position || std::stod(f[3]) != s.channels[0] || std::stod(f[5]) != s.command ||
        std::stod(f[7]) != s.latency_s || std::stoul(f[9]) != s.flags) {
      values_ok = false;
      ADD_FAILURE() << "line for cycle " << expected_cycle << ": " << line;
      break;
    }
    ++expected_cycle;
  }
  EXPECT_TRUE(values_ok);
  EXPECT_EQ(data_lines, total);
  EXPECT_EQ(last_comment, "# dropped 0 samples (ring full: 0, write failed: 0)");
  std::filesystem::remove_all(options.directory);
}

TEST(Recorder, StalledWriterMakesTheRingDropAndTheDropsAreReported) {
  TestRing ring(500);  // half a second at 1 kHz
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("stall");
  options.flush_interval_s = 0.01;
  options.buffer_bytes = 4096;
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.set_ring_drop_counter([&] { return ring.drops(); });
  recorder.start("stall", wheel_header());

  constexpr std::uint64_t total = 3000;
  std::uint64_t pushed_ok = 0;
  for (std::uint64_t c = 1; c <= total; ++c) {
    if (c == 500) {
      std::lock_guard lock(data->mutex);
      data->stall = 400ms;  // the disk stalls: each write now blocks 400 ms
    }
    if (c == 2500) {
      std::lock_guard lock(data->mutex);
      data->stall = 0ms;
    }
    // The producer never blocks: a 2000-sample burst in ~0.25 s against a
    // 500-sample ring and a writer blocked for 400 ms.
    if (ring.push(sample_for(c))) ++pushed_ok;
    if (c % 8 == 0) std::this_thread::sleep_for(1ms);
  }
  ASSERT_TRUE(wait_until([&] { return ring.size() == 0; }));
  // One more sample once the ring is empty, so every drop lies between two
  // written samples and shows as a cycle gap.
  ASSERT_TRUE(ring.push(sample_for(total + 1)));
  ++pushed_ok;
  ASSERT_TRUE(wait_until([&] { return ring.size() == 0; }));
  const RecorderStatus final = recorder.stop();
  const std::uint64_t drops = ring.drops();
  EXPECT_GT(drops, 0u);
  EXPECT_EQ(pushed_ok + drops, total + 1);
  EXPECT_EQ(final.dropped_ring, drops);
  EXPECT_EQ(final.dropped_write, 0u);
  EXPECT_EQ(final.samples_written, pushed_ok);
  // The lost samples are also visible as missing cycles in the file.
  EXPECT_EQ(final.cycle_gaps, drops);
  const auto lines = lines_of(data->contents());
  EXPECT_EQ(lines.back(), "# dropped " + std::to_string(drops) +
                              " samples (ring full: " + std::to_string(drops) + ", write failed: 0)");
  std::uint64_t data_lines = 0;
  for (const auto& l : lines) data_lines += (!l.starts_with("#") && !l.starts_with("time_s")) ? 1 : 0;
  EXPECT_EQ(data_lines, pushed_ok);
  EXPECT_EQ(recorder.status().dropped_ring_total, drops);
}

TEST(Recorder, FailingSinkCountsWriteDropsAndReportsTheError) {
  TestRing ring(1000);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("fail");
  options.flush_interval_s = 0.005;
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("fail", wall_header());
  for (std::uint64_t c = 1; c <= 5; ++c) ring.push(sample_for(c, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_written == 5; }));
  {
    std::lock_guard lock(data->mutex);
    data->fail = true;
  }
  for (std::uint64_t c = 6; c <= 25; ++c) ring.push(sample_for(c, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().dropped_write == 20; }));
  EXPECT_EQ(recorder.status().error, "write test: No space left on device");
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(final.samples_written, 5u);
  EXPECT_EQ(final.dropped_write, 20u);
  EXPECT_EQ(final.error, "write test: No space left on device");
  EXPECT_EQ(data->syncs, 0);  // no fsync after a failed write
  EXPECT_TRUE(data->closed);
}

/// What a recording's text holds: data rows (whole lines with the right
/// number of fields; anything else is a torn row), their cycles, comments.
struct FileContents {
  std::uint64_t rows = 0;
  std::uint64_t torn = 0;  ///< data lines cut short or not ended by '\n'
  std::vector<std::uint64_t> cycles;
  std::vector<std::string> comments;
};

FileContents scan(const std::string& text, std::size_t fields) {
  FileContents out;
  std::size_t begin = 0;
  while (begin < text.size()) {
    const std::size_t end = text.find('\n', begin);
    const bool ended = end != std::string::npos;
    const std::string line = text.substr(begin, ended ? end - begin : std::string::npos);
    begin = ended ? end + 1 : text.size();
    if (line.starts_with("#")) {
      out.comments.push_back(line);
      out.torn += ended ? 0 : 1;
    } else if (!line.starts_with("time_s,")) {
      const auto f = split(line);
      if (!ended || f.size() != fields) {
        ++out.torn;
        continue;
      }
      ++out.rows;
      out.cycles.push_back(std::stoull(f[1]));
    }
  }
  return out;
}

bool has_prefix(const std::vector<std::string>& lines, const std::string& prefix) {
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.starts_with(prefix); });
}

// Issue 6: after the disk filled, the file held 3686 whole rows and a torn
// one with no trailer, while the recorder said 3608 written. Now a row
// counts as written only when it is whole in the file; a torn row is cut
// back; dropped = received - written; the status says the disk is full.
TEST(RecorderDiskFull, TornRowIsCutBackAndTheCountsMatchTheFile) {
  TestRing ring(1u << 14);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("disk-full");
  options.flush_interval_s = 0.005;
  options.buffer_bytes = 1000;  // many writes, each several rows
  options.sink_factory = memory_factory(data);
  // Room for the header block and a bit over 40 rows: every write fits until
  // one stops part-way through a row.
  data->set_capacity(2000 + 40 * 60 + 17);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.set_ring_drop_counter([&] { return ring.drops(); });
  recorder.start("full", wheel_header());
  std::uint64_t cycle = 0;
  while (!recorder.status().disk_full && cycle < 100000) {
    ASSERT_TRUE(ring.push(sample_for(++cycle)));
    if (cycle % 50 == 0) {
      ASSERT_TRUE(wait_until([&] { return ring.size() == 0; }));
    }
  }
  ASSERT_TRUE(recorder.status().disk_full) << "the disk never filled";
  const RecorderStatus during = recorder.status();
  EXPECT_TRUE(during.recording);
  EXPECT_EQ(during.error, "write test: No space left on device");
  // The disk stays full: the recorder keeps draining (the RT side never
  // finds the ring full) and counts what it cannot write.
  for (int i = 0; i < 3000; ++i) ASSERT_TRUE(ring.push(sample_for(++cycle)));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_received == cycle; }));
  EXPECT_EQ(ring.drops(), 0u);

  const RecorderStatus final = recorder.stop();
  const FileContents file = scan(data->contents(), 10);
  EXPECT_EQ(file.torn, 0u) << "a partial row is left in the file";
  EXPECT_GT(data->truncations, 0) << "no write stopped part-way: the test did not tear a row";
  EXPECT_EQ(final.samples_written, file.rows);
  EXPECT_EQ(final.samples_received, cycle);
  EXPECT_EQ(final.dropped_write, final.samples_received - final.samples_written);
  EXPECT_EQ(final.dropped_ring, 0u);
  EXPECT_EQ(final.bytes_written, data->contents().size());
  ASSERT_FALSE(file.cycles.empty());
  EXPECT_EQ(file.cycles.back(), file.rows);  // rows 1..n, the first n cycles
  // Still full at stop: no trailer, and the status says so.
  EXPECT_TRUE(final.disk_full);
  EXPECT_FALSE(final.complete);
  EXPECT_FALSE(has_prefix(file.comments, "# dropped"));
  EXPECT_EQ(final.error, "write test: No space left on device");
  EXPECT_EQ(data->syncs, 0);
  EXPECT_TRUE(data->closed);
}

TEST(RecorderDiskFull, WhenSpaceReturnsARecordingResumesWithAMarkedGap) {
  TestRing ring(1u << 14);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("resume");
  options.flush_interval_s = 0.005;
  options.buffer_bytes = 1000;
  options.sink_factory = memory_factory(data);
  data->set_capacity(3000);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.set_ring_drop_counter([&] { return ring.drops(); });
  recorder.start("resume", wheel_header());
  std::uint64_t cycle = 0;
  while (!recorder.status().disk_full && cycle < 100000) {
    ASSERT_TRUE(ring.push(sample_for(++cycle)));
    if (cycle % 50 == 0) {
      ASSERT_TRUE(wait_until([&] { return ring.size() == 0; }));
    }
  }
  ASSERT_TRUE(recorder.status().disk_full);
  for (int i = 0; i < 500; ++i) ASSERT_TRUE(ring.push(sample_for(++cycle)));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_received == cycle; }));
  const std::uint64_t written_before = recorder.status().samples_written;
  const std::uint64_t lost = recorder.status().dropped_write;
  ASSERT_GT(lost, 500u);

  data->set_capacity(std::string::npos);  // space returns
  ASSERT_TRUE(wait_until([&] { return recorder.status().resumed == 1; }));
  EXPECT_FALSE(recorder.status().disk_full);
  const std::uint64_t first_after = cycle + 1;
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(ring.push(sample_for(++cycle)));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_received == cycle; }));

  const RecorderStatus final = recorder.stop();
  EXPECT_TRUE(final.complete);
  EXPECT_FALSE(final.disk_full);
  EXPECT_EQ(final.resumed, 1u);
  EXPECT_EQ(final.sections, 2u);
  EXPECT_EQ(final.samples_received, cycle);
  EXPECT_EQ(final.dropped_write, lost);
  EXPECT_EQ(final.samples_written, written_before + 200);
  EXPECT_EQ(final.samples_written + final.dropped_write, final.samples_received);
  const FileContents file = scan(data->contents(), 10);
  EXPECT_EQ(file.torn, 0u);
  EXPECT_EQ(file.rows, final.samples_written);
  // The gap is marked where it is, and says what is missing.
  const std::string gap = "# gap: " + std::to_string(lost) +
                          " samples not written while the disk was full (cycles " +
                          std::to_string(written_before + 1) + " to " + std::to_string(first_after - 1) +
                          "): write test: No space left on device";
  const auto gap_at = std::find(file.comments.begin(), file.comments.end(), gap);
  ASSERT_NE(gap_at, file.comments.end()) << data->contents().substr(0, 4000);
  EXPECT_EQ(*(gap_at - 1), "# section 2: resumed after the disk was full");
  const auto resumed_at = std::find(file.cycles.begin(), file.cycles.end(), first_after);
  ASSERT_NE(resumed_at, file.cycles.end());
  EXPECT_EQ(*(resumed_at - 1), written_before);  // the row before the gap
  EXPECT_EQ(file.comments.back(), "# dropped " + std::to_string(lost) +
                                      " samples (ring full: 0, write failed: " + std::to_string(lost) + ")");
  EXPECT_EQ(data->syncs, 1);
}

TEST(RecorderDiskFull, SceneSwitchWhileFullIsTheResumedSectionsScene) {
  TestRing ring(1u << 14);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("switch-full");
  options.flush_interval_s = 0.005;
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("switch", wheel_header());
  for (std::uint64_t c = 1; c <= 5; ++c) ring.push(sample_for(c));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_written == 5; }));
  data->set_capacity(data->contents().size());  // full from here
  ring.push(sample_for(6));
  ASSERT_TRUE(wait_until([&] { return recorder.status().disk_full; }));
  recorder.set_scene(wall_header(), 7);
  for (std::uint64_t c = 7; c <= 9; ++c) ring.push(sample_for(c, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_received == 9; }));
  data->set_capacity(std::string::npos);
  ASSERT_TRUE(wait_until([&] { return recorder.status().resumed == 1; }));
  ring.push(sample_for(10, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_received == 10; }));
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(final.samples_written, 6u);  // 1..5, then 10
  EXPECT_EQ(final.dropped_write, 4u);
  EXPECT_EQ(final.sections, 2u);
  const auto lines = lines_of(data->contents());
  // The resumed section is the wall's (no channels); its column line follows.
  const auto section = std::find(lines.begin(), lines.end(), "# section 2: resumed after the disk was full");
  ASSERT_NE(section, lines.end());
  EXPECT_NE(std::find(section, lines.end(), "# scene: wall"), lines.end());
  const auto columns =
      std::find_if(section, lines.end(), [](const auto& l) { return l.starts_with("time_s,"); });
  ASSERT_NE(columns, lines.end());
  EXPECT_EQ(*columns, "time_s,cycle,position_m,command_n,applied_n,latency_s,compute_s,flags");
  EXPECT_EQ(split(*(columns + 1))[1], "10");
}

bool write_file(const char* path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out.flush());
}

/// Runs `body` in a child process in which `dir` is a tmpfs of `bytes`,
/// mounted in the child's own mount namespace (the host never sees it).
/// Returns the body's report ("" when all is well), or nothing when this
/// host lets no process mount one (neither root nor user namespaces).
std::optional<std::string> in_small_filesystem(const std::filesystem::path& dir, std::size_t bytes,
                                               const std::function<std::string()>& body) {
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  const uid_t uid = ::getuid();
  const gid_t gid = ::getgid();
  const pid_t pid = ::fork();
  if (pid < 0) return "fork failed";
  if (pid == 0) {
    ::close(fds[0]);
    if (::unshare(CLONE_NEWNS) != 0) {
      if (::unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0) ::_exit(77);
      write_file("/proc/self/setgroups", "deny");
      write_file("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1");
      write_file("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1");
    }
    if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) ::_exit(77);
    const std::string size = "size=" + std::to_string(bytes);
    if (::mount("tmpfs", dir.c_str(), "tmpfs", 0, size.c_str()) != 0) ::_exit(77);
    const std::string report = body();
    std::size_t sent = 0;
    while (sent < report.size()) {
      const ssize_t n = ::write(fds[1], report.data() + sent, report.size() - sent);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string report;
  char chunk[4096];
  for (ssize_t n = 0; (n = ::read(fds[0], chunk, sizeof chunk)) > 0;)
    report.append(chunk, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 77) return std::nullopt;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return "the child died (status " + std::to_string(status) + ")";
  return report;
}

// The same on a real filesystem that fills: FileSink reports how far a
// write got, cuts the torn row with ftruncate, and the counts match the file.
TEST(RecorderDiskFull, RealFullFilesystemLeavesWholeRowsAndExactCounts) {
  const auto dir = temp_dir("tmpfs");
  const auto report = in_small_filesystem(dir, 64 * 1024, [&dir]() -> std::string {
    TestRing ring(1u << 14);
    RecorderOptions options;
    options.directory = dir;
    options.flush_interval_s = 0.005;
    options.buffer_bytes = 3000;  // writes of ~50 rows: the one that meets the end stops part-way
    std::string problems;
    auto check = [&problems](bool ok, const std::string& what) {
      if (!ok) problems += what + "\n";
    };
    std::uint64_t cycle = 0;
    RecorderStatus final;
    std::filesystem::path path;
    {
      Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
      path = recorder.start("real", wheel_header());
      while (!recorder.status().disk_full && cycle < 2000000) {
        ring.push(sample_for(++cycle));
        if (cycle % 100 == 0 && !wait_until([&] { return ring.size() == 0; })) return "the recorder stalled";
      }
      check(recorder.status().disk_full, "the filesystem never filled");
      for (int i = 0; i < 1000; ++i) ring.push(sample_for(++cycle));
      if (!wait_until([&] { return recorder.status().samples_received == cycle; })) return "not drained";
      final = recorder.stop();
    }
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    const FileContents file = scan(text.str(), 10);
    check(ring.drops() == 0, "the ring overflowed while the disk was full");
    check(file.torn == 0, "a partial row is left in the file");
    check(final.samples_written == file.rows, "samples_written " + std::to_string(final.samples_written) +
                                                  " but the file has " + std::to_string(file.rows) + " rows");
    check(final.samples_received == cycle, "received " + std::to_string(final.samples_received));
    check(final.dropped_write == final.samples_received - final.samples_written,
          "dropped != received - written");
    check(final.bytes_written == text.str().size(), "bytes_written is not the file's size");
    check(final.disk_full && !final.complete, "the status does not say the disk was full at stop");
    check(final.error.find("No space left on device") != std::string::npos, "error: " + final.error);
    return problems;
  });
  std::filesystem::remove_all(dir);
  if (!report) GTEST_SKIP() << "cannot mount a small tmpfs here (needs root or user namespaces)";
  EXPECT_EQ(*report, "");
}

TEST(Recorder, SamplesDrainedDuringAHoldWaitForTheSceneTheyBelongTo) {
  // The daemon learns the new scene's first cycle only after the RT loop has
  // applied it, so the recorder may already have drained its samples.
  TestRing ring(1000);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("held");
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("s", wheel_header());
  for (std::uint64_t c = 1; c <= 5; ++c) ring.push(sample_for(c, 2));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_drained == 5; }));
  recorder.hold_for_scene();
  for (std::uint64_t c = 6; c <= 7; ++c) ring.push(sample_for(c, 2));
  for (std::uint64_t c = 8; c <= 10; ++c) ring.push(sample_for(c, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_drained == 10; }));
  recorder.set_scene(wall_header(), 8);
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(final.sections, 2u);
  EXPECT_EQ(final.samples_written, 10u);
  const auto lines = lines_of(data->contents());
  std::size_t section_line = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i] == "# section 2: scene changed at cycle 8") section_line = i;
  }
  ASSERT_GT(section_line, 0u);
  EXPECT_EQ(split(lines[section_line - 1])[1], "7");
}

TEST(Recorder, AHoldWithNoSceneToComeLetsTheSamplesGoAtStop) {
  TestRing ring(1000);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("held-stop");
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("s", wheel_header());
  recorder.hold_for_scene();
  for (std::uint64_t c = 1; c <= 5; ++c) ring.push(sample_for(c, 2));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_drained == 5; }));
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(final.sections, 1u);
  EXPECT_EQ(final.samples_written, 5u);
}

TEST(Recorder, SceneSwitchStartsANewSectionAtTheGivenCycle) {
  TestRing ring(1000);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("section");
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("s", wheel_header());
  for (std::uint64_t c = 1; c <= 5; ++c) ring.push(sample_for(c, 2));
  RecordingHeader wall = wall_header();
  wall.rotary = true;
  wall.notes = {"unstable parameter set loaded with force=true"};
  recorder.set_scene(wall, 8);  // samples 6 and 7 are still the wheel's
  for (std::uint64_t c = 6; c <= 7; ++c) ring.push(sample_for(c, 2));
  for (std::uint64_t c = 8; c <= 10; ++c) ring.push(sample_for(c, 0));
  ASSERT_TRUE(wait_until([&] { return recorder.status().samples_drained == 10; }));
  const RecorderStatus final = recorder.stop();
  EXPECT_EQ(final.sections, 2u);
  EXPECT_EQ(final.samples_written, 10u);
  const auto lines = lines_of(data->contents());
  std::vector<std::string> columns;
  std::size_t section_line = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].starts_with("time_s")) columns.push_back(lines[i]);
    if (lines[i] == "# section 2: scene changed at cycle 8") section_line = i;
  }
  ASSERT_EQ(columns.size(), 2u);
  EXPECT_EQ(columns[1], "time_s,cycle,position_rad,command_n_m,applied_n_m,latency_s,compute_s,flags");
  ASSERT_GT(section_line, 0u);
  EXPECT_EQ(split(lines[section_line - 1])[1], "7");  // last wheel sample just before the new block
  const std::string text = data->contents();
  EXPECT_NE(text.find("# scene: wall\n"), std::string::npos);
  EXPECT_NE(text.find("# note: unstable parameter set loaded with force=true\n"), std::string::npos);
  std::size_t after = section_line;
  while (lines[after].starts_with("#") || lines[after].starts_with("time_s")) ++after;
  EXPECT_EQ(split(lines[after]).size(), 8u);
  EXPECT_EQ(split(lines[after])[1], "8");
}

TEST(Recorder, ExistingFilesAreNeverOverwrittenAndNamesAreChecked) {
  TestRing ring(10);
  RecorderOptions options;
  options.directory = temp_dir("names");
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  { std::ofstream(options.directory / "take.csv") << "precious\n"; }
  const auto first = recorder.start("take", wheel_header());
  EXPECT_EQ(first, options.directory / "take-1.csv");
  EXPECT_THROW(recorder.start("other", wheel_header()), RecorderError);  // one at a time
  recorder.stop();
  EXPECT_THROW(recorder.stop(), RecorderError);
  const auto second = recorder.start("take.csv", wheel_header());
  EXPECT_EQ(second, options.directory / "take-2.csv");
  recorder.stop();
  std::ifstream in(options.directory / "take.csv");
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, "precious");
  EXPECT_THROW(recorder.start("../escape.csv", wheel_header()), RecorderError);
  EXPECT_THROW(recorder.start("/tmp/x.csv", wheel_header()), RecorderError);
  const auto automatic = recorder.start("", wall_header());
  EXPECT_TRUE(
      std::regex_match(automatic.filename().string(), std::regex(R"(hapticd-wall-\d{8}T\d{6}Z\.csv)")))
      << automatic;
  recorder.stop();
  std::filesystem::remove_all(options.directory);
}

TEST(Recorder, PeriodicFlushWritesBeforeStop) {
  TestRing ring(100);
  auto data = std::make_shared<MemoryData>();
  RecorderOptions options;
  options.directory = temp_dir("flush");
  options.flush_interval_s = 0.02;
  options.sink_factory = memory_factory(data);
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  recorder.start("f", wheel_header());
  ring.push(sample_for(1));
  ASSERT_TRUE(wait_until([&] { return data->contents().find("\n0.001,1,") != std::string::npos; }, 2s));
  EXPECT_EQ(data->syncs, 0);
  recorder.stop();
  EXPECT_EQ(data->syncs, 1);
}

TEST(Recorder, StreamsGetEveryDrainedSampleRecordingOrNot) {
  TestRing ring(1000);
  RecorderOptions options;
  options.directory = temp_dir("streams");
  Recorder recorder([&](std::span<TelemetrySample> out) { return ring.pop(out); }, options);
  std::mutex m;
  std::vector<std::uint64_t> a;
  std::vector<std::uint64_t> b;
  const auto ida = recorder.add_stream([&](std::span<const TelemetrySample> batch) {
    std::lock_guard lock(m);
    for (const auto& s : batch) a.push_back(s.cycle);
  });
  recorder.add_stream([&](std::span<const TelemetrySample> batch) {
    std::lock_guard lock(m);
    for (const auto& s : batch) b.push_back(s.cycle);
  });
  for (std::uint64_t c = 1; c <= 100; ++c) ring.push(sample_for(c));
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard lock(m);
    return b.size() == 100;
  }));
  recorder.remove_stream(ida);
  for (std::uint64_t c = 101; c <= 150; ++c) ring.push(sample_for(c));
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard lock(m);
    return b.size() == 150;
  }));
  std::lock_guard lock(m);
  ASSERT_EQ(a.size(), 100u);
  for (std::uint64_t i = 0; i < 150; ++i) EXPECT_EQ(b[i], i + 1);
  for (std::uint64_t i = 0; i < 100; ++i) EXPECT_EQ(a[i], i + 1);
  EXPECT_FALSE(recorder.status().recording);
  std::filesystem::remove_all(options.directory);
}

}  // namespace
}  // namespace hapticd::daemon::recorder::recorder_test
