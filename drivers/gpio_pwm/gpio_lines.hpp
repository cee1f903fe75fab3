#pragma once
/// \file
/// Transport, part 1 of 2: the GPIO lines, through libgpiod 1.6 (the GPIO
/// character device, uAPI v1). The other part, sysfs_attributes.hpp, is
/// the PWM channel and the counter: two kernel interfaces with their own
/// failure modes, each testable on its own (the sysfs part against plain
/// files, this one only under the umockdev testbed or on gpio-sim).
///
/// Which calls run where:
/// - non-RT (configure, clear_fault, close): opening the chip, finding
///   lines, requests and releases; these allocate and throw TransportError;
/// - RT (read/write, once per period): OutputLines::set() is one
///   GPIOHANDLE_SET_LINE_VALUES ioctl for all output lines;
///   EdgeInput::read() is one non-blocking read() of the line's event
///   queue. Neither allocates, locks or throws;
/// - the quadrature thread (non-RT): QuadratureReader polls the two encoder
///   lines' event fds and publishes the decoded count through an atomic.
///
/// Lines are requested as they are (no ACTIVE_LOW flag): uAPI v1 applies
/// one flag set to a whole request, and the outputs are one request, so
/// each line's active level is applied by the caller.

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "drivers/gpio_pwm/gpio_pwm_config.hpp"
#include "drivers/gpio_pwm/quadrature_decoder.hpp"
#include "drivers/gpio_pwm/transport_error.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace hapticd::drivers::gpio_pwm {

struct LineInfo {
  unsigned offset = 0;
  std::string name;
  std::string consumer;
  bool used = false;
  bool output = false;
};

class GpioChip {
 public:
  /// Opens the chip by path, name, number or label (gpiod_chip_open_lookup).
  /// Throws TransportError (key "chip") with the reason and what to do.
  explicit GpioChip(const std::string& spec);
  ~GpioChip();
  GpioChip(const GpioChip&) = delete;
  GpioChip& operator=(const GpioChip&) = delete;

  std::string name() const;
  std::string label() const;
  unsigned num_lines() const;
  /// The offset of a configured line: its number, or the line of that name
  /// on this chip. Throws TransportError(key) when there is none.
  unsigned resolve(const LineSpec& spec, std::string_view key) const;
  LineInfo info(unsigned offset) const;
  /// "gpiochip0 (hapticd-sim, 8 lines)": for messages.
  std::string describe() const;

  gpiod_line* line(unsigned offset) const;  ///< for the request classes

 private:
  gpiod_chip* chip_ = nullptr;
  std::string spec_;
};

/// Output lines in one request: one ioctl sets them all.
class OutputLines {
 public:
  /// `keys` name the lines for errors (one per offset). Throws TransportError.
  OutputLines(const GpioChip& chip, std::span<const unsigned> offsets, std::span<const int> initial_levels,
              const std::string& consumer, std::span<const std::string> keys);
  ~OutputLines();
  OutputLines(const OutputLines&) = delete;
  OutputLines& operator=(const OutputLines&) = delete;

  /// RT: sets every line (physical levels, in the order of the offsets).
  /// Returns 0 or the errno.
  int set(std::span<const int> levels) noexcept;
  /// Reads the levels back (0 or errno).
  int get(std::span<int> levels) noexcept;
  std::size_t size() const noexcept { return count_; }

 private:
  struct Bulk;
  std::unique_ptr<Bulk> bulk_;
  std::size_t count_ = 0;
};

/// One input line watched for both edges, its event fd non-blocking.
class EdgeInput {
 public:
  EdgeInput(const GpioChip& chip, unsigned offset, const std::string& consumer, std::string_view key);
  ~EdgeInput();
  EdgeInput(const EdgeInput&) = delete;
  EdgeInput& operator=(const EdgeInput&) = delete;

  int fd() const noexcept;
  unsigned offset() const noexcept { return offset_; }
  /// RT-safe: whether an event is queued (one poll() with no wait: cheaper
  /// than a read that finds nothing on an emulated chip, the same on the
  /// kernel's). 1, 0, or -errno.
  int pending() noexcept;
  /// RT-safe: the events queued for this line, oldest first, at most
  /// min(out.size(), 16). Returns how many, 0 when none, -errno on error.
  int read(std::span<EdgeEvent> out) noexcept;
  /// The line's physical level now (1 or 0), or -errno.
  int level() noexcept;

 private:
  gpiod_line* line_ = nullptr;
  unsigned offset_ = 0;
};

/// The quadrature decoding thread: waits on both encoder lines' event fds,
/// decodes every edge (QuadratureDecoder, events of the two queues merged
/// by timestamp) and publishes the count. Not an RT thread: the loop reads
/// count() (one atomic load) once per period.
class QuadratureReader {
 public:
  struct Stats {
    std::uint64_t edges = 0;
    std::uint64_t invalid_transitions = 0;  ///< both lines changed at once
    std::uint64_t lost_edges = 0;           ///< a line reported the level it had
    std::uint64_t full_reads = 0;           ///< a read found a line's 16-event queue full: edges may be lost
    std::uint64_t wakeups = 0;
    std::uint64_t read_errors = 0;
  };

  /// Events one batch holds per line (the kernel queues 16; a few passes
  /// can gather more).
  static constexpr std::size_t batch_capacity = std::size_t{4} * kernel_event_queue_depth;

  /// Reads both lines' levels as the initial state. `a_active_low` and
  /// `b_active_low` invert a line's level before decoding.
  QuadratureReader(EdgeInput& a, EdgeInput& b, bool a_active_low, bool b_active_low, bool reverse);
  ~QuadratureReader();  ///< stops the thread
  QuadratureReader(const QuadratureReader&) = delete;
  QuadratureReader& operator=(const QuadratureReader&) = delete;

  void start();
  void stop() noexcept;
  /// RT-safe: the latest decoded count.
  std::int64_t count() const noexcept { return count_.load(std::memory_order_acquire); }
  Stats stats() const noexcept;

 private:
  void run() noexcept;
  void publish(const QuadratureDecoder& decoder) noexcept;

  EdgeInput& a_;
  EdgeInput& b_;
  bool a_invert_, b_invert_;
  QuadratureDecoder decoder_;
  int stop_fd_ = -1;
  std::thread thread_;
  // A single 64-bit atomic, not an rt/ ring or seqlock: the writer is this
  // non-RT thread and the reader the RT loop; a seqlock reader could spin on
  // a writer preempted mid-update, and a ring drops the newest when full.
  std::atomic<std::int64_t> count_{0};
  std::atomic<std::uint64_t> edges_{0}, invalid_{0}, lost_{0}, full_{0}, wakeups_{0}, read_errors_{0};
};

}  // namespace hapticd::drivers::gpio_pwm
