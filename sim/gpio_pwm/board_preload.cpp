// libhapticd-gpio-board.so: the simulated gpio-pwm board inside another
// program, so the real hapticd binary runs against it.
//
// Why a preload: libgpiod's line and event requests return file descriptors
// that the umockdev handler makes by opening emulated nodes, and a
// descriptor exists only in the process that opened it. So the board must
// live in hapticd's own process. Loaded with
//   LD_PRELOAD="libumockdev-preload.so.0 <dir>/libhapticd-gpio-board.so"
// (tests/drivers/gpio_pwm/e2e sets it up), it builds the testbed and the board
// before hapticd's main() runs, and tears them down after main() returns.
// hapticd itself links nothing of it.
//
// The board (README.md, "Simulation and tests"): gpiochip0 "hapticd-devsim"
// with lines MOTOR_EN 0, MOTOR_DIR 1, MOTOR_NFAULT 2 (active low), ENC_A 3,
// ENC_B 4, PUMP 5, BRAKE 6, MOTOR_RESET 7; /sys/class/pwm/pwmchip0 with one
// channel; /sys/bus/counter/devices/counter0/count0 (32-bit).
//
// Environment:
//   HAPTICD_GPIO_BOARD        options "key=value ...": position=counter|quadrature,
//                             period=0.001 (s, the loop's), force_at_full_duty=1 (N m or N),
//                             watchdog_periods=0, log=<file> (the board's periods, CSV, at exit),
//                             control=<fifo> (commands, one per line: "trip <reason>"),
//                             program=hapticd (the board starts only in the process running
//                             this executable: the environment reaches every child of the
//                             launcher too, e.g. `timeout` or `sh -c`)
//   HAPTICD_GPIO_BOARD_PLANT  the plant, as the loopback driver's keys ("motion=rotary damping=0.002")
//   HAPTICD_GPIO_BOARD_HAND   the scripted hand ("mode=hold trajectory=step amplitude=0.785 at=0.5")

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "drivers/loopback/loopback_config.hpp"
#include "drivers/simulation/hand_script.hpp"
#include "drivers/simulation/key_value.hpp"
#include "sim/gpio_pwm/board.hpp"

namespace {

namespace sim = hapticd::drivers::gpio_pwm::sim;
namespace simulation = hapticd::drivers::simulation;

struct BoardOptions {
  bool quadrature = false;
  double period_s = 1e-3;
  double force_at_full_duty = 1.0;
  unsigned watchdog_periods = 0;
  std::string log;
  std::string control;
  std::string program = "hapticd";
};

const char* environment(const char* name) {
  return std::getenv(name);  // NOLINT(concurrency-mt-unsafe): before main(), one thread
}

BoardOptions parse_options(const char* text) {
  BoardOptions o;
  for (const auto& [key, value] : simulation::detail::split_key_values(text, "HAPTICD_GPIO_BOARD")) {
    if (key == "position") {
      if (value != "counter" && value != "quadrature")
        throw std::invalid_argument("position=" + value + "; accepted: counter, quadrature");
      o.quadrature = value == "quadrature";
    } else if (key == "period") {
      o.period_s = std::stod(value);
    } else if (key == "force_at_full_duty") {
      o.force_at_full_duty = std::stod(value);
    } else if (key == "watchdog_periods") {
      o.watchdog_periods = static_cast<unsigned>(std::stoul(value));
    } else if (key == "log") {
      o.log = value;
    } else if (key == "control") {
      o.control = value;
    } else if (key == "program") {
      o.program = value;
    } else {
      throw std::invalid_argument(
          "unknown key " + key +
          "; accepted: position, period, force_at_full_duty, watchdog_periods, log, control, "
          "program");
    }
  }
  return o;
}

class InjectedBoard {
 public:
  explicit InjectedBoard(const BoardOptions& options) : options_(options) {
    sim::GpioChipSpec spec;
    spec.label = "hapticd-devsim";
    spec.line_names = {"MOTOR_EN", "MOTOR_DIR", "MOTOR_NFAULT", "ENC_A",
                       "ENC_B",    "PUMP",      "BRAKE",        "MOTOR_RESET"};
    gpio_ = std::make_unique<sim::UmockdevGpioTestbed>(spec);
    pwm_ = std::make_unique<sim::SimulatedPwmChip>(gpio_->root_dir(), "/sys/class/pwm/pwmchip0", 1);
    if (!options.quadrature) {
      counter_ = std::make_unique<sim::SimulatedCounter>(gpio_->root_dir(),
                                                         "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF);
    }
    auto plant = hapticd::drivers::loopback::parse_loopback_config(
        environment("HAPTICD_GPIO_BOARD_PLANT") != nullptr ? environment("HAPTICD_GPIO_BOARD_PLANT") : "");
    plant.period_s = options.period_s;
    const char* hand = environment("HAPTICD_GPIO_BOARD_HAND");
    auto simulator = std::make_unique<simulation::PlantSimulator>(
        plant,
        hand != nullptr && hand[0] != '\0' ? simulation::parse_hand_script(hand) : simulation::HandScript{});
    sim::BoardConfig config;
    config.wiring.enable = 0;
    config.wiring.direction = 1;
    config.wiring.fault = 2;
    config.wiring.fault_active_low = true;
    config.wiring.charge_pump = 5;
    config.wiring.brake = 6;
    config.wiring.reset = 7;
    if (options.quadrature) {
      config.wiring.encoder_a = 3;
      config.wiring.encoder_b = 4;
    }
    config.amplifier = {options.force_at_full_duty, options.watchdog_periods};
    config.period_s = options.period_s;
    board_ = std::make_unique<sim::SimulatedBoard>(
        *gpio_, *pwm_, counter_.get(), config, std::make_unique<sim::SimulatorPlant>(std::move(simulator)));
    if (!options.control.empty()) {
      control_fd_ = ::open(options.control.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
      if (control_fd_ < 0) throw std::runtime_error("cannot open control " + options.control);
      board_->set_before_period([this] { poll_control(); });
    }
  }

  ~InjectedBoard() {
    write_log();
    board_.reset();
    if (control_fd_ >= 0) ::close(control_fd_);
  }

 private:
  // Commands arrive between periods (the board calls this at each commit).
  void poll_control() {
    char buffer[512];
    const ssize_t n = ::read(control_fd_, buffer, sizeof buffer);
    if (n <= 0) return;
    pending_.append(buffer, static_cast<std::size_t>(n));
    for (std::size_t end = pending_.find('\n'); end != std::string::npos; end = pending_.find('\n')) {
      const std::string line = pending_.substr(0, end);
      pending_.erase(0, end + 1);
      if (line.rfind("trip ", 0) == 0) board_->trip(line.substr(5));
    }
  }

  void write_log() const {
    if (options_.log.empty() || !board_) return;
    std::ofstream out(options_.log);
    out << "period,enable,direction_positive,brake,charge_pump,pwm_fraction,motor_force,powered,position,"
           "counts\n";
    for (const auto& p : board_->history()) {
      out << p.index << ',' << p.enable << ',' << p.direction_positive << ',' << p.brake << ','
          << p.charge_pump << ',' << p.pwm_fraction << ',' << p.motor_force << ',' << p.powered << ','
          << p.position << ',' << p.counts << '\n';
    }
  }

  BoardOptions options_;
  std::unique_ptr<sim::UmockdevGpioTestbed> gpio_;
  std::unique_ptr<sim::SimulatedPwmChip> pwm_;
  std::unique_ptr<sim::SimulatedCounter> counter_;
  std::unique_ptr<sim::SimulatedBoard> board_;
  int control_fd_ = -1;
  std::string pending_;
};

InjectedBoard* board = nullptr;

// Runs after the dynamic loader is done and before main(): the testbed
// starts a worker thread, which must not inherit hapticd's signals (they are
// unblocked here; hapticd blocks them in main() and takes them with
// sigtimedwait), so every signal is blocked while it starts.
__attribute__((constructor)) void start_board() {
  const char* options = environment("HAPTICD_GPIO_BOARD");
  if (options == nullptr) return;
  BoardOptions parsed;
  try {
    parsed = parse_options(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "libhapticd-gpio-board: HAPTICD_GPIO_BOARD: %s\n", e.what());
    std::_Exit(2);
  }
  std::error_code ignored;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ignored).filename().string();
  if (!parsed.program.empty() && exe != parsed.program) return;
  if (environment("TMPDIR") == nullptr && std::filesystem::is_directory("/dev/shm")) {
    ::setenv("TMPDIR", "/dev/shm", 1);  // NOLINT(concurrency-mt-unsafe): before main(), one thread
  }
  sigset_t all, previous;
  sigfillset(&all);
  pthread_sigmask(SIG_BLOCK, &all, &previous);
  try {
    board = new InjectedBoard(parsed);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "libhapticd-gpio-board: %s\n", e.what());
    std::_Exit(2);
  }
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
}

__attribute__((destructor)) void stop_board() {
  delete board;
  board = nullptr;
}

}  // namespace
