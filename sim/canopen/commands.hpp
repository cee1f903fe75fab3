#pragma once
/// \file
/// The simulated drive's fault switches as one-line text commands (what
/// `hapticd-devsim canopen` reads on stdin and tests send):
///   fault <code> [<register>]   go to fault with this EMCY (e.g. fault 0x2310)
///   mute | unmute               stop / resume answering
///   drop-tpdo <n> | drop-tpdo all   skip the next n TPDOs / all until clear
///   sdo-abort <index>[:<sub>] <code> | sdo-abort any <code>   abort the next SDO request
///   refuse-mode on|off          acknowledge 0x6060 but keep 0x6061
///   bus-off                     the controller goes bus-off (error frame, then silence)
///   position-jump <counts>      0x6064 jumps by <counts> (+/-) once, from the next TPDO on
///   clear                       end every switch (the drive's own fault stays until reset)
///   status                      one line: state, NMT, force, counters
/// Each returns one line: "ok ..." or "error: <what was wrong>; accepted: ...".

#include <string>
#include <vector>

#include "sim/canopen/simulated_drive.hpp"

namespace hapticd::drivers::canopen::sim {

/// Applies one command to the drive; frames it sends go to `out`.
std::string apply_command(SimulatedDrive& drive, const std::string& line, Micros now,
                          std::vector<Frame>& out);

/// The status line (also the reply of "status").
std::string status_line(const SimulatedDrive& drive);

}  // namespace hapticd::drivers::canopen::sim
