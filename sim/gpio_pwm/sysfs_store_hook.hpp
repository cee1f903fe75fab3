#pragma once
/// \file
/// The store side of simulated sysfs attributes. A kernel attribute file
/// runs the driver's store() on every write and can refuse it (the PWM core
/// returns EINVAL for duty above period or period 0); a plain file in the
/// umockdev testbed cannot. Programs that link this library (tests,
/// hapticd-devsim; never the daemon) define pwrite()/pwrite64(), which, while
/// a hook is installed, hand every pwrite() to a file under the hook's
/// directory to its handler, synchronously, before anything is written:
/// the same technique as umockdev's preload, which intercepts ioctl() and
/// read() of emulated devices. The handler returns 0 (it has stored the
/// value and updated the file as the kernel shows it) or an errno (the file
/// is unchanged and pwrite() fails with it). Every other pwrite() goes
/// straight to the C library.

#include <functional>
#include <string>
#include <string_view>

namespace hapticd::drivers::gpio_pwm::sim {

class SysfsStoreHook {
 public:
  /// `path`: the real path written to (NUL-terminated); `text`: the bytes
  /// of the write. Called on the writer's thread: the RT thread when the
  /// driver writes a duty, so an accepted store must not allocate.
  using Handler = std::function<int(const char* path, std::string_view text)>;

  /// Installs the hook for files under `directory` (a real path). One hook
  /// at a time; throws std::logic_error if one is installed.
  SysfsStoreHook(std::string directory, Handler handler);
  /// Uninstalls, after any write in progress through it has returned.
  ~SysfsStoreHook();
  SysfsStoreHook(const SysfsStoreHook&) = delete;
  SysfsStoreHook& operator=(const SysfsStoreHook&) = delete;

  /// Used by the pwrite() definition.
  bool covers(std::string_view path) const noexcept;
  int store(const char* path, std::string_view text) const { return handler_(path, text); }

 private:
  std::string directory_;
  Handler handler_;
};

/// Writes through the hook so far (all hooks, this program).
unsigned long long sysfs_store_hook_calls() noexcept;

}  // namespace hapticd::drivers::gpio_pwm::sim
