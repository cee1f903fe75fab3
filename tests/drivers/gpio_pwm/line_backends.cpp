#include "tests/drivers/gpio_pwm/line_backends.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

namespace hapticd::drivers::gpio_pwm::testing_support {
namespace {

namespace fs = std::filesystem;

constexpr const char* gpio_sim_configfs = "/sys/kernel/config/gpio-sim";

class UmockdevBackend final : public LineBackend {
 public:
  explicit UmockdevBackend(const std::vector<std::string>& names) : bed_(spec(names)) {}
  std::string chip_path() const override { return bed_.chip_path(); }
  void drive_input(unsigned offset, bool level, std::uint64_t timestamp_ns) override {
    bed_.drive_input(offset, level, timestamp_ns);
  }
  bool output_level(unsigned offset) override {
    return bed_.with_chip([offset](sim::GpioChipModel& c) { return c.physical_level(offset); });
  }
  bool is_testbed() const override { return true; }
  std::uint64_t dropped_events() const override { return bed_.dropped_events(); }
  std::uint64_t requests_served() const override { return bed_.requests_served(); }

 private:
  static sim::GpioChipSpec spec(const std::vector<std::string>& names) {
    sim::GpioChipSpec s;
    s.line_names = names;
    return s;
  }
  sim::UmockdevGpioTestbed bed_;
};

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("gpio-sim: cannot write " + path);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// One gpio-sim chip made through configfs (Documentation/admin-guide/gpio/gpio-sim.rst).
class GpioSimBackend final : public LineBackend {
 public:
  explicit GpioSimBackend(const std::vector<std::string>& names)
      : device_(std::string(gpio_sim_configfs) + "/hapticd-" + std::to_string(::getpid())) {
    fs::create_directory(device_);
    const std::string bank = device_ + "/bank0";
    fs::create_directory(bank);
    write_text(bank + "/num_lines", std::to_string(names.size()));
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i].empty()) continue;
      const std::string line = bank + "/line" + std::to_string(i);
      fs::create_directory(line);
      write_text(line + "/name", names[i]);
      lines_.push_back(line);
    }
    write_text(device_ + "/live", "1");
    chip_name_ = read_text(bank + "/chip_name");
    sysfs_ = "/sys/devices/platform/" + read_text(device_ + "/dev_name") + "/" + chip_name_;
  }
  ~GpioSimBackend() override {
    std::error_code ignored;
    write_text(device_ + "/live", "0");
    for (const auto& line : lines_) fs::remove(line, ignored);
    fs::remove(device_ + "/bank0", ignored);
    fs::remove(device_, ignored);
  }
  std::string chip_path() const override { return "/dev/" + chip_name_; }
  void drive_input(unsigned offset, bool level, std::uint64_t) override {
    write_text(sysfs_ + "/sim_gpio" + std::to_string(offset) + "/pull", level ? "pull-up" : "pull-down");
  }
  bool output_level(unsigned offset) override {
    return read_text(sysfs_ + "/sim_gpio" + std::to_string(offset) + "/value") == "1";
  }
  bool is_testbed() const override { return false; }

 private:
  std::string device_, chip_name_, sysfs_;
  std::vector<std::string> lines_;
};

}  // namespace

std::string gpio_sim_unavailable_reason() {
  if (!fs::is_directory(gpio_sim_configfs)) {
    return "gpio-sim is not available on this kernel: no " + std::string(gpio_sim_configfs) +
           " (CONFIG_GPIO_SIM not built, or configfs not mounted)";
  }
  if (::geteuid() != 0) return "gpio-sim needs root to create a chip through configfs";
  return "";
}

std::unique_ptr<LineBackend> make_line_backend(const std::string& kind,
                                               const std::vector<std::string>& line_names) {
  if (kind == "umockdev") return std::make_unique<UmockdevBackend>(line_names);
  if (kind == "gpio-sim") return std::make_unique<GpioSimBackend>(line_names);
  throw std::invalid_argument("unknown line backend " + kind);
}

}  // namespace hapticd::drivers::gpio_pwm::testing_support
