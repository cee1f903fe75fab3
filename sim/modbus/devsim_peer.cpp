#include "sim/modbus/devsim_peer.hpp"

#include <unistd.h>

#include <cerrno>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "drivers/modbus/modbus_config.hpp"
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
  std::string map;
  bool no_function_23 = false;
  double alive_counter_s = 0.0;
  int priority = 0;
};

// "key=value key=value" as [device.modbus] values: true/false, numbers, text.
std::map<std::string, ParameterValue> map_values(const std::string& text) {
  std::map<std::string, ParameterValue> values;
  std::istringstream in(text);
  for (std::string item; in >> item;) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      throw std::invalid_argument("--map item \"" + item + "\" is not key=value");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    if (value == "true" || value == "false") {
      values[key] = value == "true";
      continue;
    }
    try {
      std::size_t used = 0;
      const double number = std::stod(value, &used);
      if (used == value.size()) {
        values[key] = number;
        continue;
      }
    } catch (const std::exception&) {
    }
    values[key] = value;
  }
  return values;
}

int run(const Options& o) {
  try {
    const ModbusConfig config = build_modbus_config(map_values(o.map));
    simulation::PlantSimulator simulator(
        devsim::plant_from(o.plant, o.period_s),
        o.hand.empty() ? simulation::HandScript{} : simulation::parse_hand_script(o.hand));
    SimulatorPlant plant(simulator);
    AmplifierSettings s;
    s.map = config.map;
    s.slave_id = config.slave_id;
    s.position_per_count = config.position_per_count();
    s.torque_per_count = config.torque_per_count;
    s.function_23 = !o.no_function_23;
    s.alive_counter_s = o.alive_counter_s;
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
    if (server->is_rtu())
      std::cout << "modbus amplifier: rtu " << server->slave_path() << " slave " << s.slave_id << std::endl;
    else
      std::cout << "modbus amplifier: tcp " << o.host << ":" << server->port() << " unit " << s.slave_id
                << std::endl;
    for (std::string line; std::getline(std::cin, line);)
      std::cout << run_peer_command(line, *server, amplifier) << std::endl;
    pause();  // stdin closed: serve until a signal ends the process
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "hapticd-devsim modbus: " << e.what() << "\n";
    return 2;
  }
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
            cmd->add_option("--map", options->map,
                            "register map, as [device.modbus] keys: \"torque_register=10 ...\"");
            cmd->add_flag("--no-function-23", options->no_function_23, "answer fc 23 with exception 01");
            cmd->add_option("--alive-counter", options->alive_counter_s,
                            "the watchdog register is an alive counter watched while enabled: an unchanged "
                            "value trips at once, no new value for this many s trips (0: off; hapticd's "
                            "watchdog_refresh = \"counter\")")
                ->check(CLI::Range(0.0, 60.0));
            cmd->add_option("--priority", options->priority,
                            "SCHED_FIFO priority of the server thread, as an amplifier is its own hardware "
                            "(0: none; without the privilege it says so and runs plain)")
                ->check(CLI::Range(0, 99));
            cmd->callback([options, &exit_code] { exit_code = run(*options); });
          }};
}

}  // namespace hapticd::drivers::modbus::sim
