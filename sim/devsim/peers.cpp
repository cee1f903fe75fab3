#include "sim/devsim/peers.hpp"

#include "drivers/loopback/loopback_config.hpp"
#include "sim/canopen/devsim_peer.hpp"
#include "sim/gpio_pwm/devsim_peer.hpp"
#include "sim/modbus/devsim_peer.hpp"
#include "sim/usb_hid/devsim_peer.hpp"

namespace hapticd::drivers::devsim {

const std::vector<SimulatedPeer>& simulated_peers() {
  // One line per driver with a simulated peer (its sim/ folder).
  static const std::vector<SimulatedPeer> peers{
      canopen::sim::canopen_peer(),    // sim/canopen
      canopen::sim::canbus_peer(),     // sim/canopen: the bus several drives share
      modbus::sim::modbus_peer(),      // sim/modbus
      usb_hid::sim::usb_hid_peer(),    // sim/usb_hid
      gpio_pwm::sim::gpio_pwm_peer(),  // sim/gpio_pwm
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
