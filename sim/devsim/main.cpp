// hapticd-devsim: runs a driver's simulated peer on its own (a CiA 402
// drive, a Modbus amplifier, ...) so hapticd can be tried end to end on a
// laptop. `hapticd-devsim list` names them.

#include <CLI/CLI.hpp>
#include <iostream>

#include "drivers/registry.hpp"
#include "sim/devsim/peers.hpp"

int main(int argc, char** argv) {
  namespace devsim = hapticd::drivers::devsim;
  CLI::App app{"hapticd-devsim: run a simulated device peer for a hapticd driver"};
  app.require_subcommand(1);
  int exit_code = 0;
  auto* list = app.add_subcommand("list", "the peers this build can run");
  list->callback([] {
    for (const auto& peer : devsim::simulated_peers()) std::cout << peer.kind << ": " << peer.summary << "\n";
    for (const auto& driver : hapticd::drivers::driver_registry()) {
      bool has_peer = driver.name == "loopback";  // the loopback is its own simulation
      for (const auto& peer : devsim::simulated_peers()) has_peer = has_peer || peer.kind == driver.name;
      if (!has_peer) std::cout << driver.name << ": no simulated peer yet\n";
    }
  });
  for (const auto& peer : devsim::simulated_peers()) peer.add_command(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "hapticd-devsim: " << e.what() << "\n";
    return 1;
  }
  return exit_code;
}
