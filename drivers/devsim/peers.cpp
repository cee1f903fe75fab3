#include "drivers/devsim/peers.hpp"

#include "drivers/canopen/sim/devsim_peer.hpp"
#include "drivers/gpio_pwm/sim/devsim_peer.hpp"
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/modbus/sim/devsim_peer.hpp"
#include "drivers/usb_hid/sim/devsim_peer.hpp"

namespace hapticd::drivers::devsim {

const std::vector<SimulatedPeer>& simulated_peers() {
  // One line per driver with a simulated peer (its sim/ folder).
  static const std::vector<SimulatedPeer> peers{
      canopen::sim::canopen_peer(),    // drivers/canopen/sim
      modbus::sim::modbus_peer(),      // drivers/modbus/sim
      usb_hid::sim::usb_hid_peer(),    // drivers/usb_hid/sim
      gpio_pwm::sim::gpio_pwm_peer(),  // drivers/gpio_pwm/sim
  };
  return peers;
}

void add_plant_option(CLI::App& command, std::string& text) {
  command.add_option("--plant", text,
                     "the simulated plant, as the loopback driver's keys: \"motion=linear plant=two-mass "
                     "delay=1 hand=...\" (default: the loopback's rigid wheel)");
}

simulation::PlantConfig plant_from(const std::string& text, double period_s) {
  simulation::PlantConfig config = loopback::parse_loopback_config(text);
  config.period_s = period_s;
  config.validate();
  return config;
}

}  // namespace hapticd::drivers::devsim
