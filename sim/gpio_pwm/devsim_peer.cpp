#include "sim/gpio_pwm/devsim_peer.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace hapticd::drivers::gpio_pwm::sim {

namespace {

struct Options {
  std::string plant;
  std::string hand;
  bool quadrature = false;
  double period_s = 1e-3;
  double full_scale = 1.2;
  std::string log;
  std::string control;
  std::string board_library;
  std::vector<std::string> command;
};

// The board library: --board-library, else the installed one, else the
// build tree's (this program run from its build directory).
std::string board_library(const Options& o) {
  if (!o.board_library.empty()) return o.board_library;
  for (const char* candidate : {HAPTICD_GPIO_BOARD_INSTALLED, HAPTICD_GPIO_BOARD_BUILD}) {
    if (std::filesystem::exists(candidate)) return candidate;
  }
  throw std::runtime_error(std::string("no libhapticd-gpio-board.so at ") + HAPTICD_GPIO_BOARD_INSTALLED +
                           " or " + HAPTICD_GPIO_BOARD_BUILD + "; name it with --board-library");
}

[[noreturn]] void run(const Options& o) {
  const simulation::PlantConfig plant = devsim::plant_from(o.plant, o.period_s);  // refuses a bad key now
  std::string options = std::string("position=") + (o.quadrature ? "quadrature" : "counter") +
                        " period=" + std::to_string(o.period_s) +
                        " force_at_full_duty=" + std::to_string(o.full_scale);
  if (!o.log.empty()) options += " log=" + o.log;
  if (!o.control.empty()) options += " control=" + o.control;
  const std::string program = std::filesystem::path(o.command.front()).filename().string();
  options += " program=" + program;
  const std::string preload = "libumockdev-preload.so.0 " + board_library(o);
  std::cerr
      << "gpio-pwm board (gpiochip0 \"hapticd-devsim\": MOTOR_EN 0, MOTOR_DIR 1, MOTOR_NFAULT 2 active low, "
         "ENC_A 3, ENC_B 4, PUMP 5, BRAKE 6, MOTOR_RESET 7; /sys/class/pwm/pwmchip0"
      << (o.quadrature ? "" : "; /sys/bus/counter/devices/counter0") << ") inside " << program
      << ": counts_per_unit = " << plant.counts << ", force_at_full_duty = " << o.full_scale << "\n";
  // NOLINTBEGIN(concurrency-mt-unsafe): single-threaded, replaced by execvp next
  ::setenv("LD_PRELOAD", preload.c_str(), 1);
  ::setenv("HAPTICD_GPIO_BOARD", options.c_str(), 1);
  ::setenv("HAPTICD_GPIO_BOARD_PLANT", o.plant.c_str(), 1);
  ::setenv("HAPTICD_GPIO_BOARD_HAND", o.hand.c_str(), 1);
  // NOLINTEND(concurrency-mt-unsafe)
  std::vector<std::string> args = o.command;
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  ::execvp(argv[0], argv.data());
  std::perror(("hapticd-devsim gpio-pwm: cannot run " + o.command.front()).c_str());
  std::exit(127);  // NOLINT(concurrency-mt-unsafe): single-threaded, after a failed exec
}

}  // namespace

devsim::SimulatedPeer gpio_pwm_peer() {
  devsim::SimulatedPeer peer;
  peer.kind = "gpio-pwm";
  peer.summary =
      "H-bridge, PWM channel, counter or encoder lines on an emulated gpiochip (umockdev), inside the "
      "hapticd it runs";
  peer.add_command = [](CLI::App& app, int& exit_code) {
    auto* command = app.add_subcommand(
        "gpio-pwm",
        "runs COMMAND (hapticd ...) with the simulated board inside it (drivers/gpio_pwm/README.md)");
    auto options = std::make_shared<Options>();
    devsim::add_plant_option(*command, options->plant);
    command->add_option("--hand", options->hand,
                        "the scripted hand: \"mode=hold trajectory=step amplitude=0.785\"");
    command->add_flag("--quadrature", options->quadrature,
                      "position on the ENC_A/ENC_B lines, not a counter");
    command->add_option("--full-scale", options->full_scale, "N m or N at 100 % duty (default 1.2)");
    command->add_option("--log", options->log,
                        "write the board's periods to this CSV when the program exits");
    command->add_option("--control", options->control,
                        "a FIFO the board reads commands from: \"trip <reason>\"");
    command->add_option("--board-library", options->board_library, "path of libhapticd-gpio-board.so");
    command->add_option("command", options->command, "the program and its arguments, after --")->required();
    command->callback([&exit_code, options] {
      run(*options);
      exit_code = 1;
    });
  };
  return peer;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
