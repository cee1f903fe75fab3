#include "sim/canopen/devsim_peer.hpp"

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "drivers/canopen/can_socket.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/canopen/can_bus.hpp"
#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"
#include "world/units.hpp"

namespace hapticd::drivers::canopen::sim {

namespace {

/// The shared plant simulator as the drive's plant: one step() per SYNC.
class SimulatorPlant final : public DrivePlant {
 public:
  explicit SimulatorPlant(simulation::PlantSimulator& simulator) : simulator_(simulator) {}
  double position() const override {
    double p = last_;
    if (simulator_.sense(p) == IoResult::ok && std::isfinite(p)) last_ = p;
    return last_;
  }
  double velocity() const override { return simulator_.snapshot().motor_velocity; }
  void step(double force) override { (void)simulator_.step(force); }

 private:
  simulation::PlantSimulator& simulator_;
  mutable double last_ = 0.0;
};

struct Options {
  std::string listen;
  std::string connect;  ///< unix:/path of a simulated bus (hapticd-devsim canbus), instead of listen
  int node = 1;
  std::string period = "1ms";
  double rated_torque = 1.0;
  std::string plant;
  std::string hand;
  std::string limit_switches;  ///< "NEG,POS" in m or rad ("" none; either side may be empty)
};

/// --limit-switches "NEG,POS": where the negative and positive limit
/// switches become active (homing methods 17 and 18); throws on bad text.
LimitSwitches limit_switches_from(const std::string& text) {
  LimitSwitches switches;
  if (text.empty()) return switches;
  const auto comma = text.find(',');
  if (comma == std::string::npos)
    throw std::invalid_argument("--limit-switches needs NEG,POS, got '" + text + "'");
  auto side = [&](const std::string& part) -> std::optional<double> {
    if (part.empty()) return std::nullopt;
    std::size_t used = 0;
    const double value = std::stod(part, &used);
    if (used != part.size() || !std::isfinite(value))
      throw std::invalid_argument("--limit-switches: '" + part + "' is not a position");
    return value;
  };
  switches.negative = side(text.substr(0, comma));
  switches.positive = side(text.substr(comma + 1));
  if (switches.negative && switches.positive && *switches.negative >= *switches.positive)
    throw std::invalid_argument("--limit-switches: the negative switch must lie below the positive one");
  return switches;
}

/// Blocks SIGINT and SIGTERM in every thread started from here on; sigwait() takes them.
sigset_t block_stop_signals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

int run_peer(const Options& o) {
  const bool member = !o.connect.empty();
  if (member == !o.listen.empty()) {
    std::cerr << "hapticd-devsim canopen: give one of --listen unix:/path (the drive alone) or --connect "
                 "unix:/path (a member of hapticd-devsim canbus)\n";
    return 2;
  }
  const std::string& where = member ? o.connect : o.listen;
  const std::string path(unix_path_of(where));
  if (path.empty()) {
    std::cerr << "hapticd-devsim canopen: " << (member ? "--connect" : "--listen")
              << " must be unix:/path, got '" << where << "'\n";
    return 2;
  }
  const double period_s = world::units::parse_duration_s(o.period).value_or(-1.0);
  if (!(period_s > 0.0)) {
    std::cerr << "hapticd-devsim canopen: --period '" << o.period << "' is not a duration (1ms, 250us)\n";
    return 2;
  }
  const simulation::PlantConfig plant_config = devsim::plant_from(o.plant, period_s);
  simulation::PlantSimulator simulator(plant_config, simulation::parse_hand_script(o.hand));
  SimulatorPlant plant(simulator);
  DriveSettings settings;
  settings.node_id = static_cast<std::uint8_t>(o.node);
  settings.rated_torque_mnm = static_cast<std::uint32_t>(std::llround(o.rated_torque * 1e3));
  const double unit = plant_config.motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  settings.position_units_per_si = plant_config.counts / unit;  // one increment per encoder count
  settings.velocity_units_per_si = plant_config.counts / unit;
  settings.supported_modes |= 1U << 5;  // homing mode (6), besides cyclic synchronous torque
  settings.limit_switches = limit_switches_from(o.limit_switches);
  settings.period_s = period_s;
  settings.moving_mass = plant_config.total_mass();
  SimulatedDrive drive(settings, plant);

  // SIGINT/SIGTERM end the peer: blocked here, taken by sigwait below.
  sigset_t stop_signals = block_stop_signals();

  std::unique_ptr<DriveBus> owned = member ? std::make_unique<DriveBus>(DriveBus::Member{}, path, drive)
                                           : std::make_unique<DriveBus>(path, drive);
  DriveBus& bus = *owned;
  std::atomic<bool> stop{false};
  std::thread loop([&] { bus.run(stop); });
  std::cout << "hapticd-devsim canopen: CiA 402 drive, node " << o.node
            << (member ? ", connected to the bus " : ", listening on ") << where << std::endl;
  std::thread([&bus] {
    for (std::string line; std::getline(std::cin, line);) {
      if (line.empty()) continue;
      std::cout << bus.command(line) << std::endl;
    }
  }).detach();  // blocked in getline until stdin closes; ends with the process
  int signal = 0;
  sigwait(&stop_signals, &signal);
  stop = true;
  loop.join();
  std::cout << "hapticd-devsim canopen: stopped (" << bus.command("status") << ")" << std::endl;
  return 0;
}

int run_bus(const std::string& listen) {
  const std::string path(unix_path_of(listen));
  if (path.empty()) {
    std::cerr << "hapticd-devsim canbus: --listen must be unix:/path, got '" << listen << "'\n";
    return 2;
  }
  sigset_t stop_signals = block_stop_signals();
  CanBus bus(path);
  std::atomic<bool> stop{false};
  std::thread loop([&] { bus.run(stop); });
  std::cout << "hapticd-devsim canbus: CAN bus, listening on " << listen << std::endl;
  int signal = 0;
  sigwait(&stop_signals, &signal);
  stop = true;
  loop.join();
  std::cout << "hapticd-devsim canbus: stopped (" << bus.frames_relayed() << " frames relayed, "
            << bus.deliveries_dropped() << " deliveries dropped, " << bus.malformed_messages()
            << " malformed messages)" << std::endl;
  return 0;
}

}  // namespace

devsim::SimulatedPeer canbus_peer() {
  return {"canbus",
          "a CAN bus on the unix seam: every frame a member sends reaches every other member (hapticd and "
          "hapticd-devsim canopen --connect)",
          [](CLI::App& app, int& exit_code) {
            auto listen = std::make_shared<std::string>();
            auto* cmd = app.add_subcommand(
                "canbus", "simulated CAN bus for several drives: hapticd and each drive connect to it");
            cmd->add_option("--listen", *listen,
                            "unix:/path the driver's interface and the drives' --connect name")
                ->required();
            cmd->callback([listen, &exit_code] {
              try {
                exit_code = run_bus(*listen);
              } catch (const std::exception& e) {
                std::cerr << "hapticd-devsim canbus: " << e.what() << "\n";
                exit_code = 1;
              }
            });
          }};
}

devsim::SimulatedPeer canopen_peer() {
  return {
      "canopen", "CiA 402 drive on the unix seam (NMT, SDO, PDO, SYNC, heartbeat, EMCY, fault switches)",
      [](CLI::App& app, int& exit_code) {
        auto options = std::make_shared<Options>();
        auto* cmd = app.add_subcommand("canopen", "simulated CiA 402 drive for the canopen driver");
        cmd->add_option("--listen", options->listen,
                        "unix:/path the driver's interface names (the drive alone)");
        cmd->add_option("--connect", options->connect,
                        "unix:/path of a simulated bus (hapticd-devsim canbus) to join as one of its drives");
        cmd->add_option("--node,--node-id", options->node, "the drive's node-ID")->check(CLI::Range(1, 127));
        cmd->add_option("--period", options->period, "the plant's step per SYNC: hapticd's loop period");
        cmd->add_option("--rated-torque", options->rated_torque,
                        "0x6076 motor rated torque, N m (N): 0x6071 is per mille of it")
            ->check(CLI::PositiveNumber);
        devsim::add_plant_option(*cmd, options->plant);
        cmd->add_option(
            "--limit-switches", options->limit_switches,
            "NEG,POS: positions (m or rad) beyond which the limit switches are active, for homing "
            "methods 17 and 18; either may be left empty");
        cmd->add_option(
            "--hand", options->hand,
            "the scripted hand, as the loopback's: \"mode=hold trajectory=step amplitude=0.785 at=0.5\"");
        cmd->callback([options, &exit_code] {
          try {
            exit_code = run_peer(*options);
          } catch (const std::exception& e) {
            std::cerr << "hapticd-devsim canopen: " << e.what() << "\n";
            exit_code = 1;
          }
        });
      }};
}

}  // namespace hapticd::drivers::canopen::sim
