#include "drivers/gpio_pwm/gpio_lines.hpp"

#include <fcntl.h>
#include <gpiod.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace hapticd::drivers::gpio_pwm {
namespace {

std::string chip_open_advice(int error) {
  switch (error) {
    case ENOENT:
      return "no such GPIO chip (the kernel lists them as /dev/gpiochip*; `gpiodetect` shows names and "
             "labels)";
    case EACCES:
    case EPERM:
      return "no permission: run hapticd as a user of the group that owns /dev/gpiochip* (often 'gpio') or "
             "add a udev rule";
    case ENOTTY:
    case ENODEV:
      return "not a GPIO character device";
    default:
      return system_reason(error);
  }
}

std::uint64_t nanoseconds(const timespec& ts) {
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

// ---------------------------------------------------------------- GpioChip

GpioChip::GpioChip(const std::string& spec) : spec_(spec) {
  errno = 0;
  chip_ = gpiod_chip_open_lookup(spec.c_str());
  if (chip_ == nullptr) {
    const int error = errno != 0 ? errno : ENOENT;
    throw TransportError("chip", "chip = \"" + spec + "\": " + chip_open_advice(error), error);
  }
}

GpioChip::~GpioChip() { gpiod_chip_close(chip_); }

std::string GpioChip::name() const { return gpiod_chip_name(chip_); }
std::string GpioChip::label() const { return gpiod_chip_label(chip_); }
unsigned GpioChip::num_lines() const { return gpiod_chip_num_lines(chip_); }

std::string GpioChip::describe() const {
  return name() + " (" + label() + ", " + std::to_string(num_lines()) + " lines)";
}

unsigned GpioChip::resolve(const LineSpec& spec, std::string_view key) const {
  const std::string k(key);
  if (spec.offset) {
    if (*spec.offset >= num_lines()) {
      throw TransportError(k, k + " = " + std::to_string(*spec.offset) + ": " + describe() + " has no line " +
                                  std::to_string(*spec.offset) + "; accepted: 0 to " +
                                  std::to_string(num_lines() - 1) + " or a line name");
    }
    return *spec.offset;
  }
  errno = 0;
  gpiod_line* line = gpiod_chip_find_line(chip_, spec.name.c_str());
  if (line == nullptr) {
    const int error = errno;
    throw TransportError(
        k,
        k + " = \"" + spec.name + "\": " +
            (error == ENOENT ? "no line of that name on " + describe() + " (`gpioinfo` lists them)"
                             : "looking it up on " + describe() + " failed: " + system_reason(error)),
        error);
  }
  return gpiod_line_offset(line);
}

gpiod_line* GpioChip::line(unsigned offset) const {
  gpiod_line* l = gpiod_chip_get_line(chip_, offset);
  if (l == nullptr) {
    throw TransportError(
        "chip", "line " + std::to_string(offset) + " of " + describe() + ": " + system_reason(errno), errno);
  }
  return l;
}

LineInfo GpioChip::info(unsigned offset) const {
  gpiod_line* l = line(offset);
  gpiod_line_update(l);
  LineInfo info;
  info.offset = offset;
  if (const char* n = gpiod_line_name(l)) info.name = n;
  if (const char* c = gpiod_line_consumer(l)) info.consumer = c;
  info.used = gpiod_line_is_used(l);
  info.output = gpiod_line_direction(l) == GPIOD_LINE_DIRECTION_OUTPUT;
  return info;
}

namespace {

// "enable_line = 5 (MOTOR_EN) on gpiochip0 (...)"
std::string line_words(const GpioChip& chip, unsigned offset, std::string_view key) {
  const LineInfo i = chip.info(offset);
  return std::string(key) + " = " + std::to_string(offset) + (i.name.empty() ? "" : " (" + i.name + ")") +
         " on " + chip.describe();
}

void check_free(const GpioChip& chip, unsigned offset, std::string_view key) {
  const LineInfo i = chip.info(offset);
  if (i.used) {
    throw TransportError(std::string(key),
                         line_words(chip, offset, key) + " is in use by \"" +
                             (i.consumer.empty() ? std::string("the kernel") : i.consumer) +
                             "\"; accepted: a free line",
                         EBUSY);
  }
}

}  // namespace

// ------------------------------------------------------------- OutputLines

struct OutputLines::Bulk {
  gpiod_line_bulk lines;
  std::array<int, GPIOD_LINE_BULK_MAX_LINES> values{};
};

OutputLines::OutputLines(const GpioChip& chip, std::span<const unsigned> offsets,
                         std::span<const int> initial_levels, const std::string& consumer,
                         std::span<const std::string> keys)
    : bulk_(std::make_unique<Bulk>()), count_(offsets.size()) {
  if (offsets.empty() || offsets.size() > GPIOD_LINE_BULK_MAX_LINES ||
      initial_levels.size() != offsets.size() || keys.size() != offsets.size()) {
    throw TransportError("chip", "OutputLines: offsets, levels and keys must match, 1 to 64 lines");
  }
  gpiod_line_bulk_init(&bulk_->lines);
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    check_free(chip, offsets[i], keys[i]);
    gpiod_line_bulk_add(&bulk_->lines, chip.line(offsets[i]));
  }
  if (gpiod_line_request_bulk_output(&bulk_->lines, consumer.c_str(), initial_levels.data()) != 0) {
    const int error = errno;
    throw TransportError(keys[0],
                         "requesting " + line_words(chip, offsets[0], keys[0]) +
                             (offsets.size() > 1 ? " and the other outputs" : "") +
                             " as outputs failed: " + system_reason(error),
                         error);
  }
}

OutputLines::~OutputLines() { gpiod_line_release_bulk(&bulk_->lines); }

int OutputLines::set(std::span<const int> levels) noexcept {
  if (levels.size() != count_) return EINVAL;
  return gpiod_line_set_value_bulk(&bulk_->lines, levels.data()) == 0 ? 0 : errno;
}

int OutputLines::get(std::span<int> levels) noexcept {
  if (levels.size() != count_) return EINVAL;
  return gpiod_line_get_value_bulk(&bulk_->lines, levels.data()) == 0 ? 0 : errno;
}

// --------------------------------------------------------------- EdgeInput

EdgeInput::EdgeInput(const GpioChip& chip, unsigned offset, const std::string& consumer, std::string_view key)
    : offset_(offset) {
  check_free(chip, offset, key);
  gpiod_line* line = chip.line(offset);
  if (gpiod_line_request_both_edges_events(line, consumer.c_str()) != 0) {
    const int error = errno;
    throw TransportError(
        std::string(key),
        "requesting edge events on " + line_words(chip, offset, key) + " failed: " + system_reason(error),
        error);
  }
  line_ = line;
  const int fd = gpiod_line_event_get_fd(line_);
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
    const int error = errno;
    gpiod_line_release(line_);
    throw TransportError(
        std::string(key),
        "making the event fd of " + std::string(key) + " non-blocking failed: " + system_reason(error),
        error);
  }
}

EdgeInput::~EdgeInput() { gpiod_line_release(line_); }

int EdgeInput::fd() const noexcept { return gpiod_line_event_get_fd(line_); }

int EdgeInput::pending() noexcept {
  pollfd p{fd(), POLLIN, 0};
  const int n = ::poll(&p, 1, 0);
  if (n < 0) return -errno;
  return (p.revents & POLLIN) != 0 ? 1 : 0;
}

int EdgeInput::read(std::span<EdgeEvent> out) noexcept {
  std::array<gpiod_line_event, kernel_event_queue_depth> events;
  const unsigned wanted = static_cast<unsigned>(std::min<std::size_t>(out.size(), events.size()));
  if (wanted == 0) return 0;
  const int n = gpiod_line_event_read_multiple(line_, events.data(), wanted);
  if (n < 0) return errno == EAGAIN ? 0 : -errno;
  for (int i = 0; i < n; ++i) {
    out[static_cast<std::size_t>(i)] =
        EdgeEvent{nanoseconds(events[static_cast<std::size_t>(i)].ts),
                  events[static_cast<std::size_t>(i)].event_type == GPIOD_LINE_EVENT_RISING_EDGE};
  }
  return n;
}

int EdgeInput::level() noexcept {
  const int value = gpiod_line_get_value(line_);
  return value < 0 ? -errno : value;
}

// -------------------------------------------------------- QuadratureReader

namespace {

bool initial_level(EdgeInput& line, bool invert) {
  const int level = line.level();
  if (level < 0) {
    throw TransportError("encoder_a_line",
                         "reading the level of encoder line " + std::to_string(line.offset()) +
                             " failed: " + system_reason(-level),
                         -level);
  }
  return (level != 0) != invert;
}

}  // namespace

QuadratureReader::QuadratureReader(EdgeInput& a, EdgeInput& b, bool a_active_low, bool b_active_low,
                                   bool reverse)
    : a_(a),
      b_(b),
      a_invert_(a_active_low),
      b_invert_(b_active_low),
      decoder_(quadrature_state(initial_level(a, a_active_low), initial_level(b, b_active_low)), reverse) {
  stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (stop_fd_ < 0) throw TransportError("encoder_a_line", "eventfd: " + system_reason(errno), errno);
}

QuadratureReader::~QuadratureReader() {
  stop();
  ::close(stop_fd_);
}

void QuadratureReader::start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { run(); });
}

void QuadratureReader::stop() noexcept {
  if (!thread_.joinable()) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(stop_fd_, &one, sizeof one);
  thread_.join();
  std::uint64_t drained = 0;
  [[maybe_unused]] const ssize_t m = ::read(stop_fd_, &drained, sizeof drained);
}

QuadratureReader::Stats QuadratureReader::stats() const noexcept {
  Stats s;
  s.edges = edges_.load(std::memory_order_relaxed);
  s.invalid_transitions = invalid_.load(std::memory_order_relaxed);
  s.lost_edges = lost_.load(std::memory_order_relaxed);
  s.full_reads = full_.load(std::memory_order_relaxed);
  s.wakeups = wakeups_.load(std::memory_order_relaxed);
  s.read_errors = read_errors_.load(std::memory_order_relaxed);
  return s;
}

void QuadratureReader::publish(const QuadratureDecoder& decoder) noexcept {
  edges_.store(decoder.edges_seen(), std::memory_order_relaxed);
  invalid_.store(decoder.invalid_transitions(), std::memory_order_relaxed);
  lost_.store(decoder.lost_edges(), std::memory_order_relaxed);
  count_.store(decoder.count(), std::memory_order_release);
}

namespace {

// How many of the first n events are at or before `horizon`.
std::size_t count_until(const std::array<EdgeEvent, QuadratureReader::batch_capacity>& events, std::size_t n,
                        std::uint64_t horizon) {
  std::size_t k = 0;
  while (k < n && events[k].timestamp_ns <= horizon) ++k;
  return k;
}

}  // namespace

void QuadratureReader::run() noexcept {
  constexpr std::size_t capacity = batch_capacity;
  constexpr int max_passes = 8;
  std::array<EdgeEvent, capacity> a_events, b_events;
  // Appends what one line has queued now, in the decoder's sense (active
  // low applied once, here); returns how many. A read that returns less
  // than it asked for has emptied the queue.
  const auto drain = [this](EdgeInput& line, bool invert, std::array<EdgeEvent, capacity>& events,
                            std::size_t& n) {
    std::size_t got_total = 0;
    while (n < events.size()) {
      const int queued = line.pending();
      if (queued <= 0) {
        if (queued < 0) read_errors_.fetch_add(1, std::memory_order_relaxed);
        break;
      }
      const std::size_t room = std::min<std::size_t>(kernel_event_queue_depth, events.size() - n);
      const int got = line.read(std::span<EdgeEvent>(events).subspan(n, room));
      if (got < 0) {
        read_errors_.fetch_add(1, std::memory_order_relaxed);
        break;
      }
      if (static_cast<unsigned>(got) == kernel_event_queue_depth)
        full_.fetch_add(1, std::memory_order_relaxed);
      if (invert) {
        for (std::size_t i = n; i < n + static_cast<std::size_t>(got); ++i)
          events[i].rising = !events[i].rising;
      }
      n += static_cast<std::size_t>(got);
      got_total += static_cast<std::size_t>(got);
      if (static_cast<std::size_t>(got) < room) break;
    }
    return got_total;
  };
  publish(decoder_);
  std::size_t na = 0, nb = 0;  // events taken and not decoded yet (carried over)
  for (;;) {
    std::array<pollfd, 3> fds{{{a_.fd(), POLLIN, 0}, {b_.fd(), POLLIN, 0}, {stop_fd_, POLLIN, 0}}};
    // With events carried over, a quiet pass within 1 ms decodes them (no
    // busy loop: this thread must not take the CPU from the RT loop).
    const int ready = ::poll(fds.data(), fds.size(), na + nb > 0 ? 1 : -1);
    if (ready < 0) {
      if (errno == EINTR) continue;
      read_errors_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if ((fds[2].revents & POLLIN) != 0) return;
    wakeups_.fetch_add(1, std::memory_order_relaxed);
    // The two queues are read one after the other, not atomically: an edge
    // on A can arrive while B is read, after a later edge on B was taken.
    // So both are read again until one pass finds both empty; merged by
    // timestamp, the batch then holds every edge older than the last one
    // taken, in order.
    bool quiet = false;
    for (int pass = 0; pass < max_passes && !quiet; ++pass) {
      quiet = drain(a_, a_invert_, a_events, na) + drain(b_, b_invert_, b_events, nb) == 0;
    }
    // Edges faster than the passes (no quiet pass): an edge still queued on
    // a line is newer than the last one taken from it, so only the edges up
    // to the older of the two lines' last ones are complete; the rest waits
    // for the next batch. A full batch is decoded whole (an overload: the
    // kernel's queues overflow too).
    std::size_t ka = na, kb = nb;
    if (!quiet && na < capacity && nb < capacity) {
      const std::uint64_t horizon =
          na == 0 || nb == 0 ? 0 : std::min(a_events[na - 1].timestamp_ns, b_events[nb - 1].timestamp_ns);
      ka = na == 0 || nb == 0 ? 0 : count_until(a_events, na, horizon);
      kb = na == 0 || nb == 0 ? 0 : count_until(b_events, nb, horizon);
    }
    decoder_.edges(std::span<const EdgeEvent>(a_events.data(), ka),
                   std::span<const EdgeEvent>(b_events.data(), kb));
    std::copy(a_events.begin() + static_cast<std::ptrdiff_t>(ka),
              a_events.begin() + static_cast<std::ptrdiff_t>(na), a_events.begin());
    std::copy(b_events.begin() + static_cast<std::ptrdiff_t>(kb),
              b_events.begin() + static_cast<std::ptrdiff_t>(nb), b_events.begin());
    na -= ka;
    nb -= kb;
    publish(decoder_);
  }
}

}  // namespace hapticd::drivers::gpio_pwm
