#pragma once
/// \file
/// The recorder: a non-RT thread that drains telemetry samples through a
/// callback the daemon supplies (it pops from the RT thread's SPSC ring; the
/// recorder never sees the ring type and never pushes), fans every drained
/// batch out to live stream consumers, and, while a recording is active,
/// writes the samples as CSV.
///
/// File format (docs/config.md, "Recordings"):
///   # hapticd recording               <- header block: '# ' comment lines
///   # key: value                         (version, start time, device, period,
///   # ...                                 scene and its parameters, units)
///   time_s,cycle,position_rad,...     <- column header, units in the names
///   0.001,1,0.25,...                  <- one line per sample
///   # section 2: scene changed at cycle N   <- scene switch: a new header
///   ...                                        block and column header
///   # section 3: resumed after the disk was full   <- after a full disk: a
///   # gap: K samples not written (...)                new block, the gap
///   # dropped N samples (...)         <- on stop, if the disk takes it
///
/// The recorder only pops. When the disk stalls, its thread blocks in write(),
/// the ring fills and the RT side counts failed pushes; the daemon hands that
/// counter to the recorder (set_ring_drop_counter) and the recorder reports
/// the part that fell inside the recording. Drops are never silent.
///
/// The counts match the file: a sample is written when its whole row is in
/// the file. A write that stops part-way (disk full) is cut back to the last
/// whole line (Sink::truncate), the rest counted as dropped. While the disk
/// is full the recorder keeps draining at its usual pace (the RT loop never
/// waits for it), counts what it cannot write, and retries every flush
/// interval; when a write succeeds the recording resumes with a new section
/// whose '# gap:' line says what is missing.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "daemon/telemetry.hpp"

namespace hapticd::daemon::recorder {

using daemon::ChannelDescription;
using daemon::TelemetrySample;

/// Pops up to out.size() samples from the RT ring into out; returns how many.
/// Called only from the recorder thread (single consumer).
using DrainFn = std::function<std::size_t(std::span<TelemetrySample> out)>;
/// Receives every drained batch, on the recorder thread. Must not block for
/// long: it delays draining. Decimation is the consumer's business.
using StreamFn = std::function<void(std::span<const TelemetrySample> batch)>;
/// Total number of samples the RT side failed to push (ring full), ever.
using DropCounterFn = std::function<std::uint64_t()>;

class RecorderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A write that did not complete: how far it got and why (errno).
class SinkWriteError : public RecorderError {
 public:
  SinkWriteError(const std::string& message, int error_number, std::size_t bytes_written)
      : RecorderError(message), error_number_(error_number), bytes_written_(bytes_written) {}
  int error_number() const noexcept { return error_number_; }
  /// Bytes of this write that reached the file before the error.
  std::size_t bytes_written() const noexcept { return bytes_written_; }
  /// ENOSPC or EDQUOT: out of space (or quota), which may come back.
  bool no_space() const noexcept;

 private:
  int error_number_;
  std::size_t bytes_written_;
};

/// Where the CSV bytes go. FileSink in production; tests inject slow or
/// failing sinks. Methods throw RecorderError on failure.
class Sink {
 public:
  virtual ~Sink() = default;
  /// All of it, or throw: SinkWriteError saying how many bytes got in (any
  /// other RecorderError is taken as none).
  virtual void write(std::string_view bytes) = 0;
  /// Cuts the file back to its first `size` bytes; writes continue there.
  virtual void truncate(std::uint64_t size) = 0;
  virtual void sync() = 0;  ///< durable on return (fsync)
  virtual void close() = 0;
};

/// A file opened with O_CREAT|O_EXCL (never overwrites), O_APPEND (so a
/// write after truncate() lands at the new end), mode 0640.
class FileSink final : public Sink {
 public:
  /// Throws RecorderError; errno EEXIST is reported as FileSink::Exists.
  explicit FileSink(const std::filesystem::path& path);
  ~FileSink() override;
  FileSink(const FileSink&) = delete;
  FileSink& operator=(const FileSink&) = delete;
  void write(std::string_view bytes) override;
  void truncate(std::uint64_t size) override;
  void sync() override;
  void close() override;

  class Exists : public RecorderError {
   public:
    using RecorderError::RecorderError;
  };

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// Opens a sink for a path that does not exist yet; throws FileSink::Exists if it does.
using SinkFactory = std::function<std::unique_ptr<Sink>(const std::filesystem::path&)>;

/// What the header block says about a recording (or a section of it).
struct RecordingHeader {
  std::string scene;  ///< scene name
  std::vector<std::pair<std::string, std::string>>
      parameters;                            ///< name, value with unit (rendered by the daemon)
  std::vector<ChannelDescription> channels;  ///< names/units of TelemetrySample::channels for this scene
  bool rotary = true;                        ///< position in rad and torque in N m; else m and N
  double period_s = 1e-3;
  std::string clock = "real";      ///< "real" or "virtual"
  std::string device;              ///< e.g. "loopback (rotary, rigid)"
  std::vector<std::string> notes;  ///< extra '# note: ' lines (e.g. "unstable, forced: grows x1.3/s")
  /// What starts a section with this header: "# section N: <change> at cycle C".
  std::string change = "scene changed";
  /// The flags line names bit 128, uncalibrated ([device] require_calibration).
  bool uncalibrated_flag = false;
};

/// The CSV column names for a header: fixed columns with units, scene/device
/// channels between position and command, only the channels the scene has.
std::vector<std::string> column_names(const RecordingHeader& header);
/// "rad/s" -> "rad_per_s", "N m" -> "n_m", "m/s^2" -> "m_per_s2", "" -> "".
std::string unit_suffix(std::string_view unit);

struct RecorderOptions {
  /// Relative recording names are created here (RecorderConfig via
  /// config::resolve_recording_directory). Created if missing.
  std::filesystem::path directory = ".";
  double flush_interval_s = 0.1;       ///< write buffered lines at least this often
  std::size_t batch_samples = 4096;    ///< drain at most this many per call
  std::size_t buffer_bytes = 1 << 20;  ///< write to the sink when the buffer exceeds this
  double idle_wait_s = 1e-3;           ///< sleep when the ring was empty
  SinkFactory sink_factory;            ///< default: FileSink
  /// CPUs the recorder thread may run on (empty: any), e.g. away from the RT
  /// loop's ([recorder] cpu). One that cannot be had is reported on stderr.
  std::vector<int> cpus;
};

/// Of the current or last recording, except the two totals.
struct RecorderStatus {
  bool recording = false;
  std::filesystem::path path;
  std::uint64_t sections = 0;          ///< header blocks in the file
  std::uint64_t samples_received = 0;  ///< samples the recording took from the ring
  std::uint64_t samples_written = 0;   ///< whole rows in the file
  std::uint64_t dropped_ring = 0;      ///< RT push failures during the recording
  /// Received but not in the file (disk full, write error): once stopped,
  /// exactly samples_received - samples_written.
  std::uint64_t dropped_write = 0;
  std::uint64_t cycle_gaps = 0;     ///< cycles missing between consecutive received samples (ring losses)
  std::uint64_t bytes_written = 0;  ///< the file's size: whole lines only
  /// The last write found the disk (or quota) full: rows are counted as
  /// dropped and writing is retried every flush interval.
  bool disk_full = false;
  std::uint64_t resumed =
      0;                  ///< times writing resumed after a full disk (one section and '# gap:' line each)
  bool complete = false;  ///< stopped with the trailer in the file and fsynced
  std::string error;      ///< the last write, truncate, fsync or close error ("" if none)
  std::uint64_t samples_drained = 0;     ///< since the recorder started, recording or not
  std::uint64_t dropped_ring_total = 0;  ///< RT push failures since the daemon started
};

class Recorder {
 public:
  /// Starts the recorder thread, which drains continuously from now on.
  Recorder(DrainFn drain, RecorderOptions options);
  /// Stops any recording (flush + fsync) and joins the thread.
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// The RT side's push-failure counter; read at start/stop and for status.
  void set_ring_drop_counter(DropCounterFn counter);

  /// Starts a recording. name: a file name (no '/'), ".csv" appended if it has
  /// no extension; empty: "hapticd-<scene>-<UTC time>.csv". If the file
  /// exists, "-1", "-2", ... is inserted before the extension (never
  /// overwrites). Returns the path actually used. Throws RecorderError if a
  /// recording is active, the name is not a plain file name, or the file
  /// cannot be created.
  std::filesystem::path start(const std::string& name, RecordingHeader header);

  /// The scene changed. While recording, samples with cycle >= first_cycle go
  /// to a new section (new header block and column line); earlier samples
  /// still in the ring stay in the current one. Ignored when not recording
  /// (start() takes the header of the scene loaded then).
  void set_scene(RecordingHeader header, std::uint64_t first_cycle);

  /// A scene is about to be published: samples drained from now on wait
  /// (up to 3 s, or held_capacity samples) for the set_scene() that says from
  /// which cycle the new scene holds, so none of the new scene's samples is
  /// written under the old header. set_scene() releases them.
  void hold_for_scene();
  static constexpr std::size_t held_capacity = 8192;

  /// Stops the recording: drains what the ring holds, writes the buffer and
  /// the trailer ending in '# dropped N samples', fsyncs and closes. Returns
  /// the final status (complete = false if the trailer or the fsync failed,
  /// e.g. the disk is still full: the file then ends at its last whole row).
  /// Throws RecorderError if no recording is active.
  RecorderStatus stop();

  /// Registers a live consumer; returns an id for remove_stream.
  std::uint64_t add_stream(StreamFn stream);
  void remove_stream(std::uint64_t id);

  RecorderStatus status() const;

 private:
  struct Recording;
  void run();
  void take_requests(std::unique_lock<std::mutex>& lock);
  void record(std::span<const TelemetrySample> batch);
  void deliver(std::span<const TelemetrySample> drained, bool stopping);
  void take_scenes();
  void finish();
  void publish_status();
  std::uint64_t ring_drops_now();

  DrainFn drain_;
  RecorderOptions options_;

  // mutex_ guards the mailbox (requests from other threads) and status_. It
  // is never held during I/O, so status() answers while the disk stalls.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable done_;
  bool active_ = false;  ///< between start() and the end of stop()
  std::unique_ptr<Recording> pending_start_;
  std::vector<std::pair<RecordingHeader, std::uint64_t>> pending_scenes_;
  bool stop_requested_ = false;
  bool held_ = false;  ///< hold_for_scene() until set_scene() or hold_until_
  std::chrono::steady_clock::time_point hold_until_;
  bool quit_ = false;
  RecorderStatus status_;
  DropCounterFn ring_drops_;

  std::unique_ptr<Recording> recording_;       ///< owned by the recorder thread
  std::vector<TelemetrySample> held_samples_;  ///< recorder thread: drained during a hold

  std::mutex streams_mutex_;
  std::vector<std::pair<std::uint64_t, StreamFn>> streams_;
  std::uint64_t next_stream_id_ = 1;

  std::atomic<std::uint64_t> samples_drained_{0};
  std::thread thread_;
};

}  // namespace hapticd::daemon::recorder
