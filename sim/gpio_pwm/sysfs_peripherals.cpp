#include "sim/gpio_pwm/sysfs_peripherals.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

#include "sim/gpio_pwm/kernel_sysfs_text.hpp"

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

namespace fs = std::filesystem;

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

constexpr std::array<const char*, 4> channel_attributes{"period", "duty_cycle", "enable", "polarity"};

}  // namespace

SimulatedPwmChip::SimulatedPwmChip(const std::string& root, const std::string& chip_path, unsigned npwm,
                                   const std::vector<unsigned>& exported, PwmChannelState initial)
    : chip_dir_(root + chip_path),
      npwm_(npwm),
      initial_(initial),
      hook_(chip_dir_, [this](const char* path, std::string_view text) { return store(path, text); }) {
  fs::create_directories(chip_dir_);
  write_file(chip_dir_ + "/npwm", std::to_string(npwm) + "\n");
  write_file(chip_dir_ + "/export", "");
  write_file(chip_dir_ + "/unexport", "");
  for (unsigned channel : exported) create_channel(channel);
}

void SimulatedPwmChip::create_channel(unsigned channel) {
  const std::string dir = channel_dir(channel);
  fs::create_directories(dir);
  PwmChannelModel model(initial_);
  for (const char* a : channel_attributes) write_file(dir + "/" + a, model.read(a));
  channels_.emplace(channel, model);
}

namespace {

// The file as the kernel would print the attribute: written with plain
// system calls from a stack buffer (this runs on the driver's RT thread).
void rewrite(const char* path, const char* text, std::size_t length) noexcept {
  const int fd = ::open(path, O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) return;
  [[maybe_unused]] const ssize_t n = ::write(fd, text, length);
  ::close(fd);
}

}  // namespace

// pwm_export_store()/pwm_unexport_store() and the channel attributes'
// store(). The accepted path allocates nothing.
int SimulatedPwmChip::store(const char* path_text, std::string_view text) {
  std::lock_guard lock(mutex_);
  ++writes_seen_;
  const std::string_view path(path_text);
  const std::string_view relative = path.substr(chip_dir_.size() + 1);
  const auto refuse = [&](unsigned channel, std::string_view attribute, int error) {
    refused_.push_back({channel, std::string(attribute), std::string(text), error});
    return error;
  };
  if (store_error_ != 0) return store_error_;  // not a refusal by the rules: a dead chip
  if (relative == "export" || relative == "unexport") {
    // export_store()/unexport_store(): kstrtouint(buf, 0), then ENODEV past npwm.
    unsigned channel = 0;
    if (const int error = kernel_kstrtouint(text, 0, channel); error != 0) return refuse(0, relative, error);
    if (channel >= npwm_) return refuse(channel, relative, ENODEV);
    const bool is_exported = channels_.count(channel) != 0;
    if (relative == "export") {
      if (is_exported) return refuse(channel, relative, EBUSY);
      create_channel(channel);
    } else {
      if (!is_exported) return refuse(channel, relative, ENODEV);
      channels_.erase(channel);
      fs::remove_all(channel_dir(channel));
    }
    return 0;
  }
  // pwmN/<attribute>
  const std::size_t slash = relative.find('/');
  if (relative.substr(0, 3) != "pwm" || slash == std::string_view::npos) return EACCES;  // npwm: read-only
  unsigned channel_number = 0;  // the directory the kernel named "pwm%u"
  const bool named = kernel_kstrtouint(relative.substr(3, slash - 3), 10, channel_number) == 0;
  const std::string_view attribute = relative.substr(slash + 1);
  const auto it = named ? channels_.find(channel_number) : channels_.end();
  if (it == channels_.end()) return ENODEV;
  const unsigned channel = it->first;
  if (const int error = it->second.write(attribute, text); error != 0)
    return refuse(channel, attribute, error);
  char shown[32];
  rewrite(path_text, shown, it->second.format(attribute, shown, sizeof shown));
  return 0;
}

PwmChannelState SimulatedPwmChip::state(unsigned channel) const {
  std::lock_guard lock(mutex_);
  return channels_.at(channel).state();
}

bool SimulatedPwmChip::exported(unsigned channel) const {
  std::lock_guard lock(mutex_);
  return channels_.count(channel) != 0;
}

void SimulatedPwmChip::fail_stores(int error) {
  std::lock_guard lock(mutex_);
  store_error_ = error;
}

std::vector<RefusedWrite> SimulatedPwmChip::refused() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

std::uint64_t SimulatedPwmChip::writes_seen() const {
  std::lock_guard lock(mutex_);
  return writes_seen_;
}

SimulatedCounter::SimulatedCounter(const std::string& root, const std::string& counter_path, unsigned index,
                                   std::uint64_t ceiling, const std::string& function)
    : ceiling_(ceiling) {
  if (ceiling != UINT64_MAX && ceiling > static_cast<std::uint64_t>(INT64_MAX)) {
    throw std::invalid_argument(
        "SimulatedCounter: ceiling above 2^63 - 1 (other than 2^64 - 1) is not simulated");
  }
  const std::string dir = root + counter_path + "/count" + std::to_string(index);
  fs::create_directories(dir);
  count_file_ = dir + "/count";
  write_file(dir + "/ceiling", std::to_string(ceiling) + "\n");
  write_file(dir + "/function", function + "\n");
  write_file(count_file_, "0\n");
}

void SimulatedCounter::set_position(std::int64_t counts) {
  // Wrap into 0..ceiling as the hardware counter does.
  if (ceiling_ == UINT64_MAX) {
    raw_ = static_cast<std::uint64_t>(counts);
  } else {
    const auto range = static_cast<std::int64_t>(ceiling_) + 1;
    raw_ = static_cast<std::uint64_t>(((counts % range) + range) % range);
  }
  write_file(count_file_, std::to_string(raw_) + "\n");
}

std::string SimulatedCounter::count_path() const { return count_file_; }

}  // namespace hapticd::drivers::gpio_pwm::sim
