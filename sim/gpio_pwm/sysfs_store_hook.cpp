#include "sim/gpio_pwm/sysfs_store_hook.hpp"

#include <dlfcn.h>
#include <sys/types.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <stdexcept>
#include <thread>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

std::atomic<const SysfsStoreHook*> installed{nullptr};
std::atomic<int> writers_inside{0};
std::atomic<unsigned long long> calls{0};

using pwrite_function = ssize_t (*)(int, const void*, size_t, off_t);

pwrite_function libc_pwrite(const char* name) {
  return reinterpret_cast<pwrite_function>(::dlsym(RTLD_NEXT, name));
}

ssize_t hooked_pwrite(pwrite_function real, int fd, const void* buffer, size_t count, off_t offset) {
  writers_inside.fetch_add(1, std::memory_order_acq_rel);
  const SysfsStoreHook* hook = installed.load(std::memory_order_acquire);
  if (hook != nullptr) {
    char link[64];
    std::snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    char path[PATH_MAX];
    const ssize_t n = ::readlink(link, path, sizeof path - 1);
    if (n > 0 && hook->covers(std::string_view(path, static_cast<size_t>(n)))) {
      path[n] = '\0';
      calls.fetch_add(1, std::memory_order_relaxed);
      const int error = hook->store(path, std::string_view(static_cast<const char*>(buffer), count));
      writers_inside.fetch_sub(1, std::memory_order_acq_rel);
      if (error != 0) {
        errno = error;
        return -1;
      }
      return static_cast<ssize_t>(count);
    }
  }
  writers_inside.fetch_sub(1, std::memory_order_acq_rel);
  return real(fd, buffer, count, offset);
}

}  // namespace

SysfsStoreHook::SysfsStoreHook(std::string directory, Handler handler)
    : directory_(std::move(directory)), handler_(std::move(handler)) {
  if (!directory_.empty() && directory_.back() != '/') directory_ += '/';
  const SysfsStoreHook* expected = nullptr;
  if (!installed.compare_exchange_strong(expected, this)) {
    throw std::logic_error("SysfsStoreHook: another hook is installed");
  }
}

SysfsStoreHook::~SysfsStoreHook() {
  installed.store(nullptr, std::memory_order_release);
  while (writers_inside.load(std::memory_order_acquire) != 0) std::this_thread::yield();
}

bool SysfsStoreHook::covers(std::string_view path) const noexcept {
  return path.substr(0, directory_.size()) == directory_;
}

unsigned long long sysfs_store_hook_calls() noexcept { return calls.load(std::memory_order_relaxed); }

}  // namespace hapticd::drivers::gpio_pwm::sim

// The definitions that take the place of the C library's in programs that
// link this file.
extern "C" ssize_t pwrite(int fd, const void* buffer, size_t count, off_t offset) {
  static const auto real = hapticd::drivers::gpio_pwm::sim::libc_pwrite("pwrite");
  return hapticd::drivers::gpio_pwm::sim::hooked_pwrite(real, fd, buffer, count, offset);
}

extern "C" ssize_t pwrite64(int fd, const void* buffer, size_t count, off_t offset) {
  static const auto real = hapticd::drivers::gpio_pwm::sim::libc_pwrite("pwrite64");
  return hapticd::drivers::gpio_pwm::sim::hooked_pwrite(real, fd, buffer, count, offset);
}
