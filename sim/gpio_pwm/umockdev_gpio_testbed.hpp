#pragma once
/// \file
/// An emulated /dev/gpiochipN that libgpiod 1.6 opens and drives through
/// its ordinary code paths, served from a GpioChipModel by umockdev
/// (Debian's umockdev / libumockdev-dev): the process runs with
/// LD_PRELOAD=libumockdev-preload.so.0, the testbed redirects /dev and /sys
/// to a temporary directory, and an ioctl handler
/// (umockdev_testbed_attach_ioctl, UMockdevIoctlBase "handle-ioctl" and
/// "handle-read") answers on umockdev's worker thread.
///
/// How each part of uAPI v1 is served:
/// - the chip node answers GPIO_GET_CHIPINFO_IOCTL and GPIO_GET_LINEINFO_IOCTL
///   from the model; /sys/bus/gpio/devices/<chip>/dev carries the node's
///   major:minor, which libgpiod checks before it trusts a chip;
/// - GPIO_GET_LINEHANDLE_IOCTL and GPIO_GET_LINEEVENT_IOCTL must return a
///   new file descriptor. The handler opens one of a pool of emulated
///   request nodes (/dev/umockdev-gpio/requestK, each a umockdev PTY node
///   with the same handler attached) and returns that fd: ioctls on it
///   (GPIOHANDLE_GET/SET_LINE_VALUES_IOCTL) reach the handler as ioctls of
///   request K. The fd is made in the handler's process, so the client must
///   be this same process (see the protocol note: why GPIO tests run
///   in-process);
/// - reads of an event request's fd are answered by "handle-read" from a
///   per-request queue of struct gpioevent_data holding at most 16 events,
///   as the kernel's kfifo does (an event arriving at a full queue is
///   dropped and counted); a read of fewer than 16 bytes is EINVAL; an empty
///   queue is EAGAIN for an O_NONBLOCK fd, otherwise the read completes when
///   the next event arrives. poll() is not emulated by umockdev: a doorbell
///   byte on the request's PTY is present exactly while its queue is not
///   empty, so poll() on the fd wakes as on the kernel's;
/// - closing a request fd (libgpiod releasing the lines) drops umockdev's
///   connection for it; the testbed releases the request in the model the
///   next time it is used (umockdev 0.17 does not signal the drop).
/// GPIOHANDLE_SET_CONFIG_IOCTL is answered ENOTTY (not emulated; the driver
/// does not use it).

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "sim/gpio_pwm/gpio_chip_model.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

/// True when libumockdev-preload is loaded in this process: it provides the
/// ioctl() the process calls (LD_PRELOAD naming it is not enough: the
/// loader skips a library it cannot find with a warning only).
bool umockdev_preload_active();
/// For a test program's main(): if the preload is missing, re-executes the
/// program (/proc/self/exe, same arguments) with it added to LD_PRELOAD.
/// Returns only when the preload is active (true), or false with the reason
/// on stderr: the exec failed, or LD_PRELOAD names it and it did not load
/// (the build links umockdev: a broken install, never a reason to skip).
bool ensure_umockdev_preload(int argc, char** argv);

struct GpioChipSpec {
  std::string name = "gpiochip0";
  std::string label = "hapticd-sim";
  std::vector<std::string> line_names;  ///< one per line ("" for unnamed)
  unsigned request_slots = 12;          ///< simultaneous line/event requests
};

class UmockdevGpioTestbed {
 public:
  /// Creates the testbed (one per process at a time: umockdev keys it on
  /// $UMOCKDEV_DIR). Throws std::runtime_error when the preload is missing.
  explicit UmockdevGpioTestbed(const GpioChipSpec& spec);
  ~UmockdevGpioTestbed();
  UmockdevGpioTestbed(const UmockdevGpioTestbed&) = delete;
  UmockdevGpioTestbed& operator=(const UmockdevGpioTestbed&) = delete;

  std::string root_dir() const;   ///< the testbed's real directory
  std::string chip_path() const;  ///< "/dev/<name>", as the client opens it
  /// The real path of an emulated /sys or /dev path (root_dir() + path).
  std::string host_path(const std::string& path) const;

  /// Runs `f(model)` under the testbed's lock, after releasing the
  /// requests whose fd the client has closed.
  template <class F>
  decltype(auto) with_chip(F&& f) {
    std::lock_guard lock(*mutex_);
    reap_closed_locked();
    return f(*chip_);
  }

  /// The outside world drives an input line (physical level); an event the
  /// kernel would queue is queued for the request watching the line.
  void drive_input(unsigned offset, bool physical_level, std::uint64_t timestamp_ns);
  /// Events dropped because their request's queue already held 16.
  std::uint64_t dropped_events() const;
  /// Events queued and not yet read, all requests together.
  std::size_t queued_events();
  /// Called when a read of an event request's fd has taken its events and
  /// before the client gets them (the reader is held), with the line's offset, on umockdev's worker thread,
  /// without the lock held (it may call drive_input()): lets a test put an edge exactly between the reads of
  /// two lines.
  using ReadObserver = std::function<void(unsigned offset)>;
  void set_read_observer(ReadObserver observer);
  /// Ioctls and reads served (to see the cost of the emulation).
  std::uint64_t requests_served() const;

  /// Called after every accepted GPIOHANDLE_SET_LINE_VALUES_IOCTL, on
  /// umockdev's worker thread, without the testbed's lock held (the
  /// observer may call drive_input()): the simulated board's lockstep hook.
  using ValuesObserver = std::function<void(RequestId request)>;
  void set_values_observer(ValuesObserver observer);

  struct Impl;

 private:
  void reap_closed_locked();
  std::unique_ptr<std::mutex> mutex_;
  std::unique_ptr<GpioChipModel> chip_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
