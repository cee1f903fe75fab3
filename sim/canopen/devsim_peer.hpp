#pragma once
/// \file
/// `hapticd-devsim canopen`: the simulated CiA 402 drive as a program of its
/// own, on the shared plant simulator, listening on the unix seam (or one of
/// several drives on a simulated bus: --connect unix:/tmp/bus.sock --node-id 2):
///   hapticd-devsim canopen --listen unix:/tmp/can.sock [--node 1] [--period 1ms]
///                          [--rated-torque 1] [--plant "motion=rotary damping=0.002"]
///                          [--hand "mode=hold trajectory=step amplitude=0.785 at=0.5"]
/// It prints one line when it listens, then reads fault switches on stdin
/// (sim/commands.hpp: "fault 0x2310", "drop-tpdo all", "status" ...) and
/// answers each with one line, until SIGINT or SIGTERM.

#include "sim/devsim/peers.hpp"

namespace hapticd::drivers::canopen::sim {

devsim::SimulatedPeer canopen_peer();
/// `hapticd-devsim canbus --listen unix:/path`: the simulated bus (can_bus.hpp)
/// that hapticd and several `hapticd-devsim canopen --connect unix:/path
/// --node-id N` join.
devsim::SimulatedPeer canbus_peer();

}  // namespace hapticd::drivers::canopen::sim
