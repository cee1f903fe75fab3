#include "sim/usb_hid/devsim_peer.hpp"

#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "drivers/simulation/plant_simulator.hpp"
#include "sim/usb_hid/simulated_board.hpp"
#include "sim/usb_hid/umockdev_board.hpp"

namespace hapticd::drivers::usb_hid::sim {

namespace {

volatile std::sig_atomic_t stop_requested = 0;
extern "C" void on_signal(int) { stop_requested = 1; }

/// The testbed helper needs the preload in this process: start again with it.
void reexec_with_preload(char** argv) {
  // NOLINTNEXTLINE(concurrency-mt-unsafe): single-threaded, replaced by execv next
  setenv("LD_PRELOAD", "libumockdev-preload.so.0", 1);
  execv("/proc/self/exe", argv);
  std::perror("hapticd-devsim: re-exec with libumockdev-preload");
  std::exit(1);  // NOLINT(concurrency-mt-unsafe): single-threaded start-up
}

struct Options {
  std::string plant;
  double period_s = 1e-3;
  double full_scale = 1.0;
  bool wall_clock = false;
  int axes = 1;
};

/// The [device.usb-hid] keys of the board's N-axis layout (board_reports.hpp).
std::string layout_keys(std::size_t n) {
  const std::string status = std::to_string(4 + 4 * n), tail = std::to_string(2 + 2 * n);
  return "axes = " + std::to_string(n) +
         ", motion = \"linear\", in_report_size = " + std::to_string(in_report_bytes_for(n)) +
         ", in_enabled_bit = \"" + status + ".0\", in_fault_bit = \"" + status +
         ".1\", in_watchdog_bit = \"" + status + ".2\", in_fault_code = \"" + std::to_string(5 + 4 * n) +
         ":u8\", out_report_size = " + std::to_string(out_report_bytes_for(n)) + ", out_enable_bit = \"" +
         tail + ".0\", out_reset_bit = \"" + tail + ".1\", out_deadman = \"" + std::to_string(4 + 2 * n) +
         ":u16le\"";
}

int serve(const Options& o) {
  const simulation::PlantConfig plant_config = devsim::plant_from(o.plant, o.period_s);
  if (o.axes > 1 && plant_config.motion != Motion::linear) {
    std::cerr << "hapticd-devsim usb-hid: --axes " << o.axes
              << " is a Cartesian stage of linear axes; accepted: --plant \"motion=linear ...\"\n";
    return 2;
  }
  // One plant simulator per axis, the same plant on each.
  std::vector<std::unique_ptr<simulation::PlantSimulator>> simulators;
  std::vector<std::unique_ptr<SimulatorPlant>> plants;
  std::vector<BoardAxis> axes;
  for (int k = 0; k < o.axes; ++k) {
    simulators.push_back(std::make_unique<simulation::PlantSimulator>(plant_config));
    plants.push_back(std::make_unique<SimulatorPlant>(*simulators.back()));
    axes.push_back({plants.back().get(), plant_config.resolution(), o.full_scale});
  }
  SimulatedBoard board(axes, o.period_s, o.wall_clock ? BoardClock::wall : BoardClock::deterministic);
  UmockdevUsbBoard testbed(EmulatedUsbIdentity{}, board);
  std::unique_ptr<FrameTicker> frames;
  if (o.wall_clock) frames = std::make_unique<FrameTicker>(board);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::cout << "usb-hid board 1209:0001 serial SIM0001 at " << testbed.port_path() << " ("
            << testbed.devnode() << ", full speed), counts_per_unit = " << plant_config.counts
            << ", command_full_scale = " << o.full_scale;
  if (o.axes > 1) std::cout << "\n" << o.axes << " axes, [device.usb-hid] " << layout_keys(board.axes());
  std::cout << "\nrun hapticd against it:\n  LD_PRELOAD=libumockdev-preload.so.0 UMOCKDEV_DIR="
            << testbed.root_dir() << " hapticd --config config/usb-hid.toml\n"
            << std::flush;
  while (stop_requested == 0) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const auto s = board.snapshot();
  std::cout << "served " << s.firmware.out_reports << " OUT reports, " << s.firmware.in_reports
            << " IN reports, " << s.firmware.watchdog_trips << " dead-man trips\n";
  return 0;
}

}  // namespace

devsim::SimulatedPeer usb_hid_peer() {
  devsim::SimulatedPeer peer;
  peer.kind = "usb-hid";
  peer.summary =
      "encoder/motor board 1209:0001 on an emulated USB bus (umockdev), one plant period per OUT report";
  peer.add_command = [](CLI::App& app, int& exit_code) {
    auto* command = app.add_subcommand("usb-hid", "the simulated USB board (drivers/usb_hid/README.md)");
    auto options = std::make_shared<Options>();
    devsim::add_plant_option(*command, options->plant);
    command->add_option("--full-scale", options->full_scale, "N m or N at the largest command (default 1)");
    command
        ->add_option("--axes", options->axes,
                     "encoder/motor pairs on the board, one plant each (2 to 6: a linear stage; default 1)")
        ->check(CLI::Range(1, static_cast<int>(max_board_axes)));
    command->add_flag("--wall-clock", options->wall_clock,
                      "the board's dead-man runs on the wall clock (as a real board's would)");
    command->callback([&exit_code, options] {
      if (!UmockdevUsbBoard::preload_active()) {
        std::vector<std::string> args;
        std::ifstream cmdline("/proc/self/cmdline");
        for (std::string arg; std::getline(cmdline, arg, '\0');) args.push_back(arg);
        std::vector<char*> argv;
        argv.reserve(args.size() + 1);
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        reexec_with_preload(argv.data());
      }
      exit_code = serve(*options);
    });
  };
  return peer;
}

}  // namespace hapticd::drivers::usb_hid::sim
