#include "sim/modbus/devsim_peer.hpp"

#include <unistd.h>

#include <cerrno>
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include "drivers/simulation/hand_script.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/modbus/amplifier_server.hpp"
#include "sim/modbus/peer_commands.hpp"
#include "sim/modbus/simulator_plant.hpp"

namespace hapticd::drivers::modbus::sim {

namespace {

struct Options {
  std::string transport = "tcp";
  std::string host = "127.0.0.1";
  int port = 0;
  double period_s = 1e-3;
  std::string plant;
  std::string hand;
  AmplifierSettings amplifier;
  double counts = 16384.0;
  std::string word_order = "high-first";
  std::string state_table = "holding";
  std::string enable_by = "control-word";
  bool no_function_23 = false;
  int priority = 0;
};

/// The amplifier's settings from the options; the position scale follows the plant's motion.
AmplifierSettings amplifier_settings(const Options& o, Motion motion) {
  AmplifierSettings s = o.amplifier;
  s.position_per_count = (motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0) / o.counts;
  s.function_23 = !o.no_function_23;
  s.word_order = o.word_order == "low-first" ? WordOrder32::low_word_first : WordOrder32::high_word_first;
  s.state_table = o.state_table == "input" ? StateTable::input : StateTable::holding;
  s.enable_by = o.enable_by == "coil" ? EnableBy::coil : EnableBy::control_word;
  return s;
}

void announce(const AmplifierServer& server, const Options& o, int slave_id) {
  if (server.is_rtu())
    std::cout << "modbus amplifier: rtu " << server.slave_path() << " slave " << slave_id << std::endl;
  else
    std::cout << "modbus amplifier: tcp " << o.host << ":" << server.port() << " unit " << slave_id
              << std::endl;
}

int run(const Options& o) {
  try {
    const simulation::PlantConfig plant_config = devsim::plant_from(o.plant, o.period_s);
    simulation::PlantSimulator simulator(
        plant_config, o.hand.empty() ? simulation::HandScript{} : simulation::parse_hand_script(o.hand));
    SimulatorPlant plant(simulator);
    const AmplifierSettings s = amplifier_settings(o, plant_config.motion);
    Amplifier amplifier(s, plant);
    auto server = o.transport == "rtu" ? AmplifierServer::rtu_pty(amplifier)
                                       : AmplifierServer::tcp(amplifier, o.host, o.port);
    server->start();
    if (o.priority > 0) {
      if (const int e = server->make_realtime(o.priority); e != 0)
        std::cerr << "hapticd-devsim modbus: cannot run SCHED_FIFO " << o.priority << " ("
                  << (e == EPERM ? "not permitted" : "errno " + std::to_string(e))
                  << "): answering at normal priority" << std::endl;
    }
    announce(*server, o, s.slave_id);
    for (std::string line; std::getline(std::cin, line);)
      std::cout << run_peer_command(line, *server, amplifier) << std::endl;
    pause();  // stdin closed: serve until a signal ends the process
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "hapticd-devsim modbus: " << e.what() << "\n";
    return 2;
  }
}

/// The amplifier's own settings, as its configuration tool would set them.
void add_amplifier_options(CLI::App& cmd, Options& o) {
  cmd.add_option("--slave-id", o.amplifier.slave_id, "RTU: the slave address it answers (TCP: any unit id)")
      ->check(CLI::Range(1, 247));
  cmd.add_option("--counts", o.counts, "position counts per revolution (rotary) or metre (linear)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--torque-per-count", o.amplifier.torque_per_count, "N m (N) of one torque-command count")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--word-order", o.word_order, "which of registers 0-1 (2-3) holds the high word")
      ->check(CLI::IsMember({"high-first", "low-first"}));
  cmd.add_option("--state-table", o.state_table,
                 "registers 0-5 are holding (fc 3, 23) or input registers (fc 4)")
      ->check(CLI::IsMember({"holding", "input"}));
  cmd.add_option("--enable-by", o.enable_by, "the power stage follows control word 12 bit 0, or coil 12")
      ->check(CLI::IsMember({"control-word", "coil"}));
  cmd.add_flag("--watchdog-any-frame", o.amplifier.watchdog_any_frame,
               "every valid request restarts the watchdog, not only writes of register 11");
  cmd.add_flag("--no-function-23", o.no_function_23, "answer fc 23 with exception 01");
  cmd.add_option(
         "--alive-counter", o.amplifier.alive_counter_s,
         "the watchdog register is an alive counter watched while enabled: an unchanged value trips at "
         "once, no new value for this many s trips (0: off; hapticd's watchdog_refresh = \"counter\")")
      ->check(CLI::Range(0.0, 60.0));
}

}  // namespace

devsim::SimulatedPeer modbus_peer() {
  return {"modbus", "a Modbus servo amplifier (libmodbus server, TCP or RTU on a pty) in front of the plant",
          [](CLI::App& app, int& exit_code) {
            auto options = std::make_shared<Options>();
            auto* cmd = app.add_subcommand("modbus", "simulated Modbus amplifier; commands on stdin (help)");
            cmd->add_option("--transport", options->transport, "tcp or rtu (a pseudo-terminal)")
                ->check(CLI::IsMember({"tcp", "rtu"}));
            cmd->add_option("--host", options->host, "TCP: address to listen on");
            cmd->add_option("--port", options->port, "TCP: port (0: a free one, printed)");
            cmd->add_option("--period", options->period_s,
                            "the plant's period, s (one step per command write)");
            devsim::add_plant_option(*cmd, options->plant);
            cmd->add_option("--hand", options->hand, "the scripted hand, as the loopback's hand keys");
            add_amplifier_options(*cmd, *options);
            cmd->add_option("--priority", options->priority,
                            "SCHED_FIFO priority of the server thread, as an amplifier is its own hardware "
                            "(0: none; without the privilege it says so and runs plain)")
                ->check(CLI::Range(0, 99));
            cmd->callback([options, &exit_code] { exit_code = run(*options); });
          }};
}

}  // namespace hapticd::drivers::modbus::sim
