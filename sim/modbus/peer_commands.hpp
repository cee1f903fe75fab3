#pragma once
/// \file
/// The simulated amplifier's command line, for `hapticd-devsim modbus` and
/// the end-to-end tests that drive it as its own process: one command per
/// line on standard input, one reply line each.
///
///   exception CODE [COUNT]   the next COUNT requests get exception CODE (hex 0x04 or decimal)
///   timeout [COUNT]          the next COUNT requests are lost (no reply)
///   crc [COUNT]              the next COUNT replies carry a wrong CRC (RTU only)
///   drop                     the connection is closed at the next request (TCP)
///   late MS [COUNT]          the next COUNT replies come MS milliseconds late
///   fault BITS               the amplifier's protection sets these fault bits (power stage off)
///   position-jump COUNTS     the position registers jump by COUNTS (+/-) once, from the next reply on
///   state                    one line of JSON: enabled, fault, torque, steps, watchdog ...
///   help                     the commands
///
/// Replies start with "ok" or "error: " (what was wrong and what is accepted).

#include <string>

#include "sim/modbus/amplifier_server.hpp"

namespace hapticd::drivers::modbus::sim {

std::string run_peer_command(const std::string& line, AmplifierServer& server, Amplifier& amplifier);

/// The state line: {"enabled":true,"fault":0,"torque":0.25,"torque_counts":250,"steps":1234,...}
std::string state_json(const AmplifierState& state);

}  // namespace hapticd::drivers::modbus::sim
