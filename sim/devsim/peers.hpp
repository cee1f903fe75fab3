#pragma once
/// \file
/// The simulated peers `hapticd-devsim` can run on their own, so a person can
/// try a driver end to end without hardware: `hapticd-devsim canopen
/// --listen unix:/tmp/can.sock`, then hapticd with that interface. Each
/// driver's sim/ adds one entry here (one line in peers.cpp), as each driver
/// adds one line to drivers/registry.cpp.

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "drivers/simulation/plant_config.hpp"

namespace hapticd::drivers::devsim {

struct SimulatedPeer {
  std::string kind;     ///< the driver it answers ("canopen")
  std::string summary;  ///< one line
  /// Adds the peer's subcommand (its options and its callback, which runs the
  /// peer until SIGINT/SIGTERM and sets the exit code through `exit_code`).
  std::function<void(CLI::App& app, int& exit_code)> add_command;
};

const std::vector<SimulatedPeer>& simulated_peers();

/// The plant behind a peer, as the loopback's keys in one option:
/// --plant "motion=linear plant=two-mass delay=1" (drivers/loopback/README.md).
/// The text is parsed by plant_from(); the period is the peer's own option.
void add_plant_option(CLI::App& command, std::string& text);
/// Throws drivers::ParameterError naming the key.
simulation::PlantConfig plant_from(const std::string& text, double period_s);

}  // namespace hapticd::drivers::devsim
