#include "drivers/gpio_pwm/sysfs_attributes.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>
#include <utility>

#include "drivers/gpio_pwm/sysfs_value.hpp"

namespace hapticd::drivers::gpio_pwm {
namespace {

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

std::string first_line(std::string text) {
  const std::size_t newline = text.find('\n');
  if (newline != std::string::npos) text.resize(newline);
  return text;
}

}  // namespace

// ---------------------------------------------------------- SysfsAttribute

SysfsAttribute::SysfsAttribute(std::string path, bool writable, std::string_view key)
    : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), (writable ? O_RDWR : O_RDONLY) | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    std::string advice;
    if (error == EACCES || error == EPERM) {
      advice =
          " (hapticd's user needs write access: a udev rule giving the group write permission on the "
          "PWM/counter attributes is the usual way)";
    }
    throw TransportError(std::string(key),
                         std::string(key) + ": cannot open " + path_ + ": " + system_reason(error) + advice,
                         error);
  }
}

SysfsAttribute::~SysfsAttribute() {
  if (fd_ >= 0) ::close(fd_);
}

SysfsAttribute::SysfsAttribute(SysfsAttribute&& other) noexcept
    : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)) {}

SysfsAttribute& SysfsAttribute::operator=(SysfsAttribute&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

int SysfsAttribute::read_u64(std::uint64_t& out) const noexcept {
  char text[sysfs_u64_text_size + 8];
  const ssize_t n = ::pread(fd_, text, sizeof text, 0);
  if (n < 0) return errno;
  const auto value = parse_sysfs_u64(std::string_view(text, static_cast<std::size_t>(n)));
  if (!value) return EBADMSG;
  out = *value;
  return 0;
}

int SysfsAttribute::write_u64(std::uint64_t value) const noexcept {
  char text[sysfs_u64_text_size];
  const std::size_t length = format_sysfs_u64(value, text);
  const ssize_t n = ::pwrite(fd_, text, length, 0);
  if (n < 0) return errno;
  return static_cast<std::size_t>(n) == length ? 0 : EIO;
}

std::string SysfsAttribute::read_text() const {
  char text[256];
  const ssize_t n = ::pread(fd_, text, sizeof text, 0);
  if (n < 0) throw TransportError("", "reading " + path_ + ": " + system_reason(errno), errno);
  return first_line(std::string(text, static_cast<std::size_t>(n)));
}

int SysfsAttribute::write_text(std::string_view text) const noexcept {
  const ssize_t n = ::pwrite(fd_, text.data(), text.size(), 0);
  if (n < 0) return errno;
  return static_cast<std::size_t>(n) == text.size() ? 0 : EIO;
}

// --------------------------------------------------------------- PwmOutput

void PwmOutput::export_channel(const Settings& s) {
  const std::string channel = std::to_string(s.channel);
  {
    SysfsAttribute exporter(s.chip_dir + "/export", true, "pwm_channel");
    const int error = exporter.write_text(channel + "\n");
    // EBUSY: exported meanwhile, or requested by a kernel driver (a pwm-fan,
    // a backlight): the wait below tells which.
    if (error != 0 && error != EBUSY) {
      throw TransportError("pwm_channel",
                           "pwm_channel = " + channel + ": exporting it through " + exporter.path() +
                               " failed: " + system_reason(error),
                           error);
    }
  }
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + std::chrono::duration_cast<clock::duration>(
                                           std::chrono::duration<double>(s.export_timeout_s));
  const std::string enable = channel_dir_ + "/enable";
  while (::access(enable.c_str(), W_OK) != 0) {
    if (clock::now() >= deadline) {
      throw TransportError(
          "export_timeout",
          "pwm_channel = " + channel + ": " + enable + " was not writable " +
              std::to_string(s.export_timeout_s) +
              " s after the export (is the channel owned by a kernel driver, or is udev slow to "
              "set permissions?)");
    }
    throw_if_stopped(s.stop, "gpio-pwm: waiting for " + enable + " after the export");
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void PwmOutput::write_or_throw(const SysfsAttribute& attribute, std::uint64_t value, const char* key) {
  if (const int error = attribute.write_u64(value); error != 0) {
    throw TransportError(key,
                         std::string(key) + ": writing " + std::to_string(value) + " to " + attribute.path() +
                             " failed: " + system_reason(error),
                         error);
  }
}

PwmOutput::PwmOutput(const Settings& s) : channel_dir_(s.chip_dir + "/pwm" + std::to_string(s.channel)) {
  if (!exists(s.chip_dir)) {
    throw TransportError(
        "pwm_chip",
        "pwm_chip = " + s.chip_dir + " does not exist (the kernel lists PWM chips in /sys/class/pwm)",
        ENOENT);
  }
  std::uint64_t npwm = 0;
  if (SysfsAttribute(s.chip_dir + "/npwm", false, "pwm_chip").read_u64(npwm) != 0 || s.channel >= npwm) {
    throw TransportError("pwm_channel", "pwm_channel = " + std::to_string(s.channel) + ": " + s.chip_dir +
                                            " has " + std::to_string(npwm) + " channel(s); accepted: 0 to " +
                                            std::to_string(npwm == 0 ? 0 : npwm - 1));
  }
  if (!exists(channel_dir_)) export_channel(s);
  period_ = SysfsAttribute(channel_dir_ + "/period", true, "pwm_period");
  duty_ = SysfsAttribute(channel_dir_ + "/duty_cycle", true, "pwm_period");
  enable_ = SysfsAttribute(channel_dir_ + "/enable", true, "pwm_channel");
  const SysfsAttribute polarity(channel_dir_ + "/polarity", true, "pwm_inversed");

  std::uint64_t enabled = 0;
  if (period_.read_u64(timing_.period_ns) != 0 || duty_.read_u64(timing_.duty_ns) != 0 ||
      enable_.read_u64(enabled) != 0) {
    throw TransportError("pwm_channel", "reading the state of " + channel_dir_ + " failed");
  }
  const std::string wanted_polarity = s.inversed ? "inversed" : "normal";
  if (polarity.read_text() != wanted_polarity) {
    // Legacy drivers refuse a polarity change while enabled (EBUSY), and
    // the core refuses any state with period 0 (EINVAL): off, then a
    // period, then the polarity.
    if (enabled != 0) {
      write_or_throw(duty_, 0, "pwm_period");
      timing_.duty_ns = 0;
      write_or_throw(enable_, 0, "pwm_channel");
      enabled = 0;
    }
    if (timing_.period_ns == 0) {
      write_or_throw(period_, s.period_ns, "pwm_period");
      timing_.period_ns = s.period_ns;
    }
    if (const int error = polarity.write_text(wanted_polarity + "\n"); error != 0) {
      throw TransportError("pwm_inversed",
                           "pwm_inversed: writing " + wanted_polarity + " to " + polarity.path() +
                               " failed: " + system_reason(error),
                           error);
    }
  }
  if (const int error = set_timing({s.period_ns, 0}); error != 0) {
    throw TransportError("pwm_period",
                         "pwm_period = " + std::to_string(s.period_ns) + " ns: " + channel_dir_ +
                             " refused it: " + system_reason(error),
                         error);
  }
  if (enabled == 0) write_or_throw(enable_, 1, "pwm_channel");
}

int PwmOutput::set_timing(const PwmTiming& target) noexcept {
  const PlanResult result = plan_pwm_writes(timing_, target);
  if (!result.ok) return EINVAL;
  for (const PwmWrite& w : result.plan) {
    const bool period = w.attribute == PwmAttribute::period;
    if (const int error = (period ? period_ : duty_).write_u64(w.value_ns); error != 0) return error;
    (period ? timing_.period_ns : timing_.duty_ns) = w.value_ns;
    writes_.store(writes_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);  // single writer
  }
  return 0;
}

int PwmOutput::set_duty(std::uint64_t duty_ns) noexcept { return set_timing({timing_.period_ns, duty_ns}); }

// ------------------------------------------------------------ CounterInput

CounterInput::CounterInput(const std::string& counter_dir, unsigned index) {
  const std::string count_dir = counter_dir + "/count" + std::to_string(index);
  if (!exists(counter_dir)) {
    throw TransportError("counter",
                         "counter = " + counter_dir +
                             " does not exist (the kernel lists counters in /sys/bus/counter/devices)",
                         ENOENT);
  }
  if (!exists(count_dir)) {
    throw TransportError("counter_count",
                         "counter_count = " + std::to_string(index) + ": " + counter_dir + " has no count" +
                             std::to_string(index),
                         ENOENT);
  }
  count_ = SysfsAttribute(count_dir + "/count", false, "counter");
  std::uint64_t probe = 0;
  if (const int error = count_.read_u64(probe); error != 0) {
    throw TransportError("counter", "counter: reading " + count_.path() + " failed: " + system_reason(error),
                         error);
  }
  if (exists(count_dir + "/ceiling")) {
    if (SysfsAttribute(count_dir + "/ceiling", false, "counter").read_u64(ceiling_) != 0) {
      throw TransportError("counter", "counter: " + count_dir + "/ceiling is not a number");
    }
  }
  if (exists(count_dir + "/function"))
    function_ = SysfsAttribute(count_dir + "/function", false, "counter").read_text();
}

}  // namespace hapticd::drivers::gpio_pwm
