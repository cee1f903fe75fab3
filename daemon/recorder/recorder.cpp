#include "daemon/recorder/recorder.hpp"

#include "daemon/system/thread_placement.hpp"
#include "world/text.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <system_error>

#ifndef HAPTICD_VERSION
#define HAPTICD_VERSION "unknown"
#endif

namespace hapticd::daemon::recorder {

namespace {

using world::text::errno_text;

void append_double(std::string& out, double value) { world::text::append_number(out, value); }

void append_u64(std::string& out, std::uint64_t value) {
  char buffer[24];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, ec == std::errc{} ? end : buffer);
}

/// Current CLOCK_REALTIME as ISO 8601 UTC with nanoseconds, and as seconds.
std::pair<std::string, std::string> realtime_now() {
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  std::tm utc{};
  gmtime_r(&now.tv_sec, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &utc);
  char nanos[16];
  std::snprintf(nanos, sizeof nanos, "%09ld", static_cast<long>(now.tv_nsec));
  return {std::string(date) + "." + nanos + "Z", std::to_string(now.tv_sec) + "." + nanos};
}

std::string compact_utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%dT%H%M%SZ", &utc);
  return text;
}

std::string sanitize(std::string_view name) {
  std::string out;
  for (const char c : name) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '-' || c == '.';
    out += keep ? c : '_';
  }
  return out;
}

/// 'name' with its control characters shown as \n, \r, \t or \xNN, so a
/// message about it stays one line.
std::string shown_name(std::string_view name) {
  std::string out = "'";
  for (const char c : name) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (byte < 0x20 || byte == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", byte);
      out += hex;
    } else {
      out += c;
    }
  }
  return out + "'";
}

}  // namespace

// ---------------------------------------------------------------- FileSink

bool SinkWriteError::no_space() const noexcept { return error_number_ == ENOSPC || error_number_ == EDQUOT; }

FileSink::FileSink(const std::filesystem::path& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0640);
  if (fd_ < 0) {
    const int error = errno;
    const std::string message = "cannot create " + path.string() + ": " + errno_text(error);
    if (error == EEXIST) throw Exists(message);
    throw RecorderError(message);
  }
}

FileSink::~FileSink() {
  if (fd_ >= 0) ::close(fd_);
}

void FileSink::write(std::string_view bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    // A full disk takes part of a write (the short count) and refuses the
    // next with ENOSPC: the caller gets how far it got.
    const ssize_t n = ::write(fd_, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      const int error = errno;
      if (error == EINTR) continue;
      throw SinkWriteError("write " + path_.string() + ": " + errno_text(error), error, written);
    }
    written += static_cast<std::size_t>(n);
  }
}

void FileSink::truncate(std::uint64_t size) {
  if (::ftruncate(fd_, static_cast<off_t>(size)) != 0) {
    throw RecorderError("truncate " + path_.string() + ": " + errno_text(errno));
  }
}

void FileSink::sync() {
  if (::fsync(fd_) != 0) throw RecorderError("fsync " + path_.string() + ": " + errno_text(errno));
}

void FileSink::close() {
  if (fd_ < 0) return;
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) throw RecorderError("close " + path_.string() + ": " + errno_text(errno));
}

// ---------------------------------------------------------------- columns

std::string unit_suffix(std::string_view unit) {
  std::string out;
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const char c = unit[i];
    if (c == '/') {
      out += "_per_";
    } else if (c == ' ' || c == '*' || c == '.') {
      if (!out.empty() && out.back() != '_') out += '_';
    } else if (c == '^') {
      // m/s^2 -> m_per_s2
    } else if (c >= 'A' && c <= 'Z') {
      out += static_cast<char>(c - 'A' + 'a');
    } else {
      out += c;
    }
  }
  return out;
}

namespace {
std::string with_unit(std::string_view name, std::string_view unit) {
  const std::string suffix = unit_suffix(unit);
  std::string base = sanitize(name);
  if (suffix.empty() || base.ends_with("_" + suffix)) return base;
  return base + "_" + suffix;
}
}  // namespace

std::vector<std::string> column_names(const RecordingHeader& header) {
  const std::string_view position_unit = header.rotary ? "rad" : "m";
  const std::string_view force_unit = header.rotary ? "N m" : "N";
  std::vector<std::string> names = {"time_s", "cycle", with_unit("position", position_unit)};
  for (const auto& channel : header.channels) names.push_back(with_unit(channel.name, channel.unit));
  names.push_back(with_unit("command", force_unit));
  names.push_back(with_unit("applied", force_unit));
  names.push_back("latency_s");
  names.push_back("compute_s");
  names.push_back("flags");
  return names;
}

// ---------------------------------------------------------------- Recording

namespace {

/// One whole line (a row, a trailer line) or header block in the buffer: the
/// unit a torn write is cut back to.
struct Piece {
  enum class Kind : std::uint8_t { row, header, other };
  std::size_t end = 0;      ///< offset in the buffer just past it
  std::uint64_t cycle = 0;  ///< rows: the sample's cycle
  Kind kind = Kind::other;
};

enum class Writing : std::uint8_t {
  ok,
  disk_full,  ///< no space: count, keep draining, retry every flush interval
  failed,     ///< any other error: nothing more is written
};

}  // namespace

struct Recorder::Recording {
  std::filesystem::path path;
  std::unique_ptr<Sink> sink;
  std::string buffer;
  std::vector<Piece> pieces;  ///< what the buffer holds, in order
  RecordingHeader header;
  std::deque<std::pair<RecordingHeader, std::uint64_t>> next_sections;
  std::uint64_t sections = 0;  ///< header blocks in the file or the buffer
  std::uint64_t samples_received = 0;
  std::uint64_t samples_written = 0;  // whole rows in the file
  std::uint64_t dropped_write = 0;
  std::uint64_t cycle_gaps = 0;
  std::uint64_t bytes_written = 0;  // the file's size
  std::uint64_t ring_baseline = 0;
  std::uint64_t ring_drops = 0;
  bool have_last_cycle = false;
  std::uint64_t last_cycle = 0;
  Writing writing = Writing::ok;
  std::string error;
  std::uint64_t resumed = 0;
  bool complete = false;
  // The rows not written since the last one that was (disk full).
  std::uint64_t outage_samples = 0;
  std::uint64_t outage_first_cycle = 0;
  std::uint64_t outage_last_cycle = 0;
  std::chrono::steady_clock::time_point last_write = std::chrono::steady_clock::now();

  /// A header block: `opening` (its first line or lines), the key: value
  /// lines, the column line.
  void append_header(const std::string& opening) {
    ++sections;
    const auto [iso, seconds] = realtime_now();
    std::string& b = buffer;
    b += opening;
    b += "# hapticd_version: " HAPTICD_VERSION "\n";
    b += "# section: " + std::to_string(sections) + "\n";
    b += "# start_utc: " + iso + "\n";
    b += "# start_clock_realtime_s: " + seconds + "\n";
    b += "# device: " + header.device + "\n";
    b += std::string("# motion: ") + (header.rotary ? "rotary" : "linear") + "\n";
    b += "# clock: " + header.clock + "\n";
    b += "# period_s: ";
    append_double(b, header.period_s);
    b += "\n# scene: " + header.scene + "\n";
    for (const auto& [name, value] : header.parameters) b += "# parameter " + name + ": " + value + "\n";
    for (const auto& note : header.notes) b += "# note: " + note + "\n";
    const std::vector<std::string> names = column_names(header);
    const std::string_view position_unit = header.rotary ? "rad" : "m";
    const std::string_view force_unit = header.rotary ? "N m" : "N";
    b += "# units: time_s s; cycle periods since loop start; " + names[2] + " " + std::string(position_unit);
    for (std::size_t i = 0; i < header.channels.size(); ++i) {
      b += "; " + names[3 + i] + " " + (header.channels[i].unit.empty() ? "1" : header.channels[i].unit);
    }
    const std::size_t k = 3 + header.channels.size();
    b += "; " + names[k] + " " + std::string(force_unit) + " (scene output before the limit); " +
         names[k + 1] + " " + std::string(force_unit) + " (sent to the device); latency_s s; compute_s s\n";
    b += "# flags: bits 1 fault_latched, 2 torque_limited, 4 read_error, 8 overrun, 16 unstable_forced, 32 "
         "position_jump, 64 stale_position";
    b += header.uncalibrated_flag ? ", 128 uncalibrated\n" : "\n";
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (i > 0) b += ',';
      b += names[i];
    }
    b += '\n';
    pieces.push_back({buffer.size(), 0, Piece::Kind::header});
  }

  /// The scene (or the origin) changed: a new section from the sample at
  /// first_cycle on. With nothing being written, the section that resumes
  /// writing takes the header.
  void start_section(std::uint64_t first_cycle) {
    if (writing != Writing::ok) return;
    append_header("# section " + std::to_string(sections + 1) + ": " + header.change + " at cycle " +
                  std::to_string(first_cycle) + "\n");
  }

  void lose(std::uint64_t cycle) {
    ++dropped_write;
    if (outage_samples++ == 0) outage_first_cycle = cycle;
    outage_last_cycle = cycle;
  }

  /// "# gap: ..." for the rows not written since the last one that was.
  std::string gap_line(std::string_view where) const {
    return "# gap: " + std::to_string(outage_samples) + " samples not written " + std::string(where) +
           " (cycles " + std::to_string(outage_first_cycle) + " to " + std::to_string(outage_last_cycle) +
           "): " + error + "\n";
  }

  void append_sample(const TelemetrySample& s) {
    ++samples_received;
    if (have_last_cycle && s.cycle > last_cycle + 1) cycle_gaps += s.cycle - last_cycle - 1;
    have_last_cycle = true;
    last_cycle = s.cycle;
    if (writing != Writing::ok) {
      lose(s.cycle);
      return;
    }
    std::string& b = buffer;
    append_double(b, s.time_s);
    b += ',';
    append_u64(b, s.cycle);
    b += ',';
    append_double(b, s.position);
    for (std::size_t i = 0; i < header.channels.size(); ++i) {
      b += ',';
      if (i < s.channel_count && i < max_telemetry_channels_) {
        append_double(b, s.channels[i]);
      } else {
        b += "nan";
      }
    }
    b += ',';
    append_double(b, s.command);
    b += ',';
    append_double(b, s.applied);
    b += ',';
    append_double(b, s.latency_s);
    b += ',';
    append_double(b, s.compute_s);
    b += ',';
    append_u64(b, s.flags);
    b += '\n';
    pieces.push_back({buffer.size(), s.cycle, Piece::Kind::row});
  }

  /// Writes the buffer. What reached the file is kept up to its last whole
  /// piece (a torn one is cut off); what did not is counted as dropped.
  void write_out() {
    last_write = std::chrono::steady_clock::now();
    if (buffer.empty()) return;
    std::size_t reached = buffer.size();
    try {
      sink->write(buffer);
    } catch (const SinkWriteError& e) {
      reached = std::min(e.bytes_written(), buffer.size());
      writing = e.no_space() ? Writing::disk_full : Writing::failed;
      error = e.what();
    } catch (const std::exception& e) {
      reached = 0;
      writing = Writing::failed;
      error = e.what();
    }
    keep(reached);
    buffer.clear();
    pieces.clear();
  }

  /// Accounts for a write that reached `reached` bytes into the buffer.
  void keep(std::size_t reached) {
    std::size_t whole = 0;
    for (const Piece& piece : pieces) {
      if (piece.end <= reached) {
        whole = piece.end;
        if (piece.kind == Piece::Kind::row) {
          ++samples_written;
          outage_samples = 0;
        }
      } else if (piece.kind == Piece::Kind::row) {
        lose(piece.cycle);
      } else if (piece.kind == Piece::Kind::header) {
        --sections;
      }
    }
    if (whole < reached) {
      try {
        sink->truncate(bytes_written + whole);
      } catch (const std::exception& e) {
        // The torn line stays: nothing more may follow it.
        writing = Writing::failed;
        error += "; the file ends in a partial line: " + std::string(e.what());
        whole = reached;
      }
    }
    bytes_written += whole;
  }

  /// After a full disk: a new section whose '# gap:' line says what is missing.
  /// Written at once; if the disk is still full it is cut back and counted nowhere.
  void try_resume() {
    writing = Writing::ok;
    const std::string opening =
        sections == 0 ? "# hapticd recording\n"
                      : "# section " + std::to_string(sections + 1) + ": resumed after the disk was full\n";
    append_header(opening + gap_line("while the disk was full"));
    write_out();
    if (writing == Writing::ok) {
      ++resumed;
      outage_samples = 0;
    }
  }

  static constexpr std::size_t max_telemetry_channels_ = daemon::max_telemetry_channels;
};

// ---------------------------------------------------------------- Recorder

Recorder::Recorder(DrainFn drain, RecorderOptions options)
    : drain_(std::move(drain)), options_(std::move(options)) {
  if (!drain_) throw RecorderError("recorder: no drain callback");
  held_samples_.reserve(held_capacity);
  if (options_.batch_samples == 0) options_.batch_samples = 1;
  if (!options_.sink_factory) {
    options_.sink_factory = [](const std::filesystem::path& path) {
      return std::make_unique<FileSink>(path);
    };
  }
  thread_ = std::thread([this] {
    hapticd::daemon::system::name_this_thread("hapticd-rec");
    run();
  });
  const auto problem = hapticd::daemon::system::pin_thread(thread_.native_handle(), options_.cpus);
  if (!problem.empty())
    std::fprintf(stderr, "hapticd: recorder thread: %s; it runs on any CPU\n", problem.c_str());
}

Recorder::~Recorder() {
  bool active = false;
  {
    std::lock_guard lock(mutex_);
    active = active_;
  }
  if (active) {
    try {
      stop();
    } catch (...) {
      // the status keeps the error; a destructor cannot report it
    }
  }
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Recorder::set_ring_drop_counter(DropCounterFn counter) {
  std::lock_guard lock(mutex_);
  ring_drops_ = std::move(counter);
}

std::uint64_t Recorder::ring_drops_now() {
  DropCounterFn counter;
  {
    std::lock_guard lock(mutex_);
    counter = ring_drops_;
  }
  return counter ? counter() : 0;
}

std::filesystem::path Recorder::start(const std::string& name, RecordingHeader header) {
  {
    std::lock_guard lock(mutex_);
    if (active_) throw RecorderError("a recording is already active: " + status_.path.string());
  }
  std::string file =
      name.empty() ? "hapticd-" + sanitize(header.scene) + "-" + compact_utc_now() + ".csv" : name;
  // A control character (a newline, a carriage return ...) would break the
  // lines of every log and listing that shows the name.
  const bool control_character = std::any_of(file.begin(), file.end(), [](char c) {
    return static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) == 0x7f;
  });
  if (file.find('/') != std::string::npos || file == "." || file == ".." || control_character) {
    throw RecorderError("recording name " + shown_name(name) +
                        " is not a file name; accepted: a file name without '/' or control characters "
                        "(newline, carriage return, tab, ...), created in " +
                        options_.directory.string());
  }
  if (!std::filesystem::path(file).has_extension()) file += ".csv";
  std::error_code ec;
  std::filesystem::create_directories(options_.directory, ec);
  if (ec) throw RecorderError("cannot create " + options_.directory.string() + ": " + ec.message());

  auto rec = std::make_unique<Recording>();
  const std::filesystem::path wanted = options_.directory / file;
  const std::string stem = wanted.stem().string();
  const std::string extension = wanted.extension().string();
  for (int attempt = 0; attempt <= 999 && !rec->sink; ++attempt) {
    const std::filesystem::path candidate =
        attempt == 0 ? wanted : options_.directory / (stem + "-" + std::to_string(attempt) + extension);
    try {
      rec->sink = options_.sink_factory(candidate);
      rec->path = candidate;
    } catch (const FileSink::Exists&) {
      continue;
    }
  }
  if (!rec->sink)
    throw RecorderError("cannot create " + wanted.string() + ": it and its -1 .. -999 variants exist");

  rec->buffer.reserve(options_.buffer_bytes + 65536);
  rec->header = std::move(header);
  rec->append_header("# hapticd recording\n");
  rec->ring_baseline = ring_drops_now();
  std::filesystem::path path = rec->path;
  {
    std::lock_guard lock(mutex_);
    if (active_) throw RecorderError("a recording is already active: " + status_.path.string());
    active_ = true;
    pending_start_ = std::move(rec);
    pending_scenes_.clear();
    held_ = false;
    status_ = RecorderStatus{};
    status_.recording = true;
    status_.path = path;
    status_.sections = 1;
  }
  wake_.notify_all();
  return path;
}

void Recorder::set_scene(RecordingHeader header, std::uint64_t first_cycle) {
  {
    std::lock_guard lock(mutex_);
    if (!active_) return;
    pending_scenes_.emplace_back(std::move(header), first_cycle);
    held_ = false;
  }
  wake_.notify_all();
}

void Recorder::hold_for_scene() {
  std::lock_guard lock(mutex_);
  if (!active_) return;
  held_ = true;
  hold_until_ = std::chrono::steady_clock::now() + std::chrono::seconds(3);
}

RecorderStatus Recorder::stop() {
  std::unique_lock lock(mutex_);
  if (!active_) throw RecorderError("no recording is active");
  stop_requested_ = true;
  wake_.notify_all();
  done_.wait(lock, [this] { return !active_; });
  return status_;
}

std::uint64_t Recorder::add_stream(StreamFn stream) {
  std::lock_guard lock(streams_mutex_);
  const std::uint64_t id = next_stream_id_++;
  streams_.emplace_back(id, std::move(stream));
  return id;
}

void Recorder::remove_stream(std::uint64_t id) {
  std::lock_guard lock(streams_mutex_);
  std::erase_if(streams_, [id](const auto& entry) { return entry.first == id; });
}

RecorderStatus Recorder::status() const {
  RecorderStatus copy;
  DropCounterFn counter;
  {
    std::lock_guard lock(mutex_);
    copy = status_;
    counter = ring_drops_;
  }
  copy.samples_drained = samples_drained_.load(std::memory_order_relaxed);
  if (counter) copy.dropped_ring_total = counter();
  return copy;
}

void Recorder::publish_status() {
  if (!recording_) return;
  const Recording& rec = *recording_;
  std::lock_guard lock(mutex_);
  status_.recording = true;
  status_.path = rec.path;
  status_.sections = rec.sections;
  status_.samples_received = rec.samples_received;
  status_.samples_written = rec.samples_written;
  status_.dropped_write = rec.dropped_write;
  status_.dropped_ring = rec.ring_drops;
  status_.cycle_gaps = rec.cycle_gaps;
  status_.bytes_written = rec.bytes_written;
  status_.disk_full = rec.writing == Writing::disk_full;
  status_.resumed = rec.resumed;
  status_.complete = rec.complete;
  status_.error = rec.error;
}

void Recorder::take_requests(std::unique_lock<std::mutex>& lock) {
  if (pending_start_) {
    recording_ = std::move(pending_start_);
    held_samples_.clear();
  }
  take_scenes();
  (void)lock;
}

/// Caller holds mutex_.
void Recorder::take_scenes() {
  if (recording_) {
    for (auto& scene : pending_scenes_) recording_->next_sections.push_back(std::move(scene));
  }
  pending_scenes_.clear();
}

/// After each drain: the scene changes asked for by now apply to what was
/// just drained (a set_scene() made before its samples were pushed is never
/// missed); during a hold the samples wait for the set_scene() to come.
void Recorder::deliver(std::span<const TelemetrySample> drained, bool stopping) {
  bool hold = false;
  {
    std::lock_guard lock(mutex_);
    take_scenes();
    if (held_ && (stopping || std::chrono::steady_clock::now() >= hold_until_)) held_ = false;
    hold = held_;
  }
  if (hold && held_samples_.size() + drained.size() <= held_capacity) {
    held_samples_.insert(held_samples_.end(), drained.begin(), drained.end());
    return;
  }
  if (!held_samples_.empty()) {
    record(held_samples_);
    held_samples_.clear();
  }
  if (!drained.empty()) record(drained);
}

void Recorder::record(std::span<const TelemetrySample> batch) {
  Recording& rec = *recording_;
  for (const TelemetrySample& sample : batch) {
    while (!rec.next_sections.empty() && sample.cycle >= rec.next_sections.front().second) {
      rec.header = std::move(rec.next_sections.front().first);
      const std::uint64_t first_cycle = rec.next_sections.front().second;
      rec.next_sections.pop_front();
      rec.start_section(std::max(first_cycle, sample.cycle));
    }
    rec.append_sample(sample);
  }
  if (rec.buffer.size() >= options_.buffer_bytes) rec.write_out();
}

void Recorder::finish() {
  Recording& rec = *recording_;
  rec.ring_drops = ring_drops_now() - rec.ring_baseline;
  const auto [iso, seconds] = realtime_now();
  rec.write_out();  // the samples first, so the counts are final
  if (rec.writing != Writing::failed) {
    // Still full: the trailer is tried anyway (the disk may have room again),
    // with the gap at the end said first.
    std::string tail = rec.writing == Writing::disk_full ? rec.gap_line("at the end") : std::string();
    rec.writing = Writing::ok;
    tail += "# stop_utc: " + iso + "\n# stop_clock_realtime_s: " + seconds + "\n";
    tail += "# samples_written: " + std::to_string(rec.samples_written) + "\n";
    tail += "# cycle_gaps: " + std::to_string(rec.cycle_gaps) + "\n";
    tail += "# dropped " + std::to_string(rec.ring_drops + rec.dropped_write) +
            " samples (ring full: " + std::to_string(rec.ring_drops) +
            ", write failed: " + std::to_string(rec.dropped_write) + ")\n";
    rec.buffer = std::move(tail);
    rec.pieces = {{rec.buffer.size(), 0, Piece::Kind::other}};  // all of it or none
    rec.write_out();
  }
  if (rec.writing == Writing::ok) {
    try {
      rec.sink->sync();
      rec.complete = true;
    } catch (const std::exception& e) {
      rec.error = e.what();
    }
  }
  try {
    rec.sink->close();
  } catch (const std::exception& e) {
    if (rec.error.empty()) rec.error = e.what();
    rec.complete = false;
  }
  publish_status();
  recording_.reset();
}

void Recorder::run() {
  std::vector<TelemetrySample> batch(options_.batch_samples);
  const auto flush_interval = std::chrono::duration<double>(options_.flush_interval_s);
  const auto idle_wait = std::chrono::duration<double>(options_.idle_wait_s);
  for (;;) {
    bool stop_now = false;
    bool quit = false;
    {
      std::unique_lock lock(mutex_);
      take_requests(lock);
      stop_now = stop_requested_;
      quit = quit_;
    }
    // On stop, drain what the ring holds now (bounded: the RT side keeps pushing).
    std::size_t rounds = stop_now ? 64 : 1;
    std::size_t n = 0;
    do {
      n = drain_(std::span<TelemetrySample>(batch));
      if (n > batch.size()) n = batch.size();
      samples_drained_.fetch_add(n, std::memory_order_relaxed);
      const std::span<const TelemetrySample> drained(batch.data(), n);
      if (n > 0) {
        std::lock_guard lock(streams_mutex_);
        for (auto& [id, stream] : streams_) stream(drained);
      }
      if (recording_) deliver(drained, stop_now);
    } while (--rounds > 0 && n == batch.size());

    if (recording_) {
      if (std::chrono::steady_clock::now() - recording_->last_write >= flush_interval) {
        if (recording_->writing == Writing::disk_full) {
          recording_->try_resume();
        } else {
          recording_->write_out();
        }
      }
      recording_->ring_drops = ring_drops_now() - recording_->ring_baseline;
      if (stop_now) {
        finish();
      } else {
        publish_status();
      }
    }
    if (stop_now) {
      {
        std::lock_guard lock(mutex_);
        stop_requested_ = false;
        active_ = false;
        status_.recording = false;
      }
      done_.notify_all();
    }
    if (quit) return;
    if (n < batch.size()) {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, idle_wait,
                     [this] { return quit_ || stop_requested_ || pending_start_ != nullptr; });
    }
  }
}

}  // namespace hapticd::daemon::recorder
