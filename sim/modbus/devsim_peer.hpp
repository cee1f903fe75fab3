#pragma once
/// \file
/// `hapticd-devsim modbus`: the simulated amplifier as a program of its own
/// (TCP on a port, or RTU on a pseudo-terminal it prints), commanded on
/// standard input (sim/peer_commands.hpp).
#include "sim/devsim/peers.hpp"

namespace hapticd::drivers::modbus::sim {

devsim::SimulatedPeer modbus_peer();

}  // namespace hapticd::drivers::modbus::sim
