#include "sim/canopen/commands.hpp"

#include <cstdio>
#include <sstream>

#include "sim/canopen/sdo_server.hpp"

namespace hapticd::drivers::canopen::sim {

namespace {

constexpr const char* accepted =
    "fault <code> [<register>], mute, unmute, drop-tpdo <n>|all, sdo-abort <index>[:<sub>]|any <code>, "
    "refuse-mode on|off, bus-off, position-jump <counts>, clear, status";

std::string error(const std::string& what) { return "error: " + what + "; accepted: " + accepted; }

bool parse_u32(const std::string& text, std::uint32_t& out) {
  try {
    std::size_t used = 0;
    const unsigned long v = std::stoul(text, &used, 0);
    if (used != text.size() || v > 0xFFFFFFFFUL) return false;
    out = static_cast<std::uint32_t>(v);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

using Words = std::vector<std::string>;

std::string fault_command(SimulatedDrive& drive, const Words& words, Micros now, std::vector<Frame>& out) {
  std::uint32_t code = 0, reg = 0;
  if (!parse_u32(words[1], code) || code > 0xFFFF || code == 0)
    return error("fault needs an error code 0x0001..0xFFFF");
  if (words.size() == 3 && (!parse_u32(words[2], reg) || reg > 0xFF))
    return error("the error register is 0x00..0xFF");
  EmergencyFault f;
  f.error_code = static_cast<std::uint16_t>(code);
  if (words.size() == 3) f.error_register = static_cast<std::uint8_t>(reg);
  drive.inject_fault(f, now, out);
  return "ok " + drive.fault_reason();
}

std::string drop_tpdo_command(SimulatedDrive& drive, const Words& words) {
  if (words[1] == "all") {
    drive.drop_tpdos(-1);
    return "ok dropping every TPDO";
  }
  std::uint32_t count = 0;
  if (!parse_u32(words[1], count) || count == 0) return error("drop-tpdo needs a count >= 1 or all");
  drive.drop_tpdos(count);
  return "ok dropping " + std::to_string(count) + " TPDOs";
}

std::string sdo_abort_command(SimulatedDrive& drive, const Words& words) {
  std::uint32_t code = 0;
  if (!parse_u32(words[2], code)) return error("sdo-abort needs an abort code, e.g. 0x08000022");
  std::optional<Address> address;
  if (words[1] != "any") {
    const std::string& a = words[1];
    const auto colon = a.find(':');
    std::uint32_t index = 0, sub = 0;
    if (!parse_u32(a.substr(0, colon), index) || index > 0xFFFF ||
        (colon != std::string::npos && (!parse_u32(a.substr(colon + 1), sub) || sub > 0xFF)))
      return error("sdo-abort needs <index>[:<sub>] like 0x6060:0, or any");
    address = Address{static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub)};
  }
  drive.abort_next_sdo(address, code);
  return "ok the next SDO request" + (address ? " for " + to_text(*address) : std::string()) +
         " gets abort " + words[2] + " (" + std::string(abort_words(code)) + ")";
}

std::string position_jump_command(SimulatedDrive& drive, const Words& words) {
  // A whole number of increments, either sign: up to 2^32 (a 32-bit
  // counter's whole range); INTEGER32 0x6064 wraps.
  try {
    std::size_t used = 0;
    const long long counts = std::stoll(words[1], &used, 0);
    if (used == words[1].size() && counts != 0 && counts >= -(1LL << 32) && counts <= (1LL << 32)) {
      drive.jump_position(counts);
      return "ok 0x6064 jumps by " + std::to_string(counts) + " increments from the next TPDO";
    }
  } catch (const std::exception&) {
  }
  return error("position-jump needs a whole number of increments, nonzero, within +/-4294967296");
}

/// The commands of one word.
std::optional<std::string> switch_command(SimulatedDrive& drive, const std::string& verb, Micros now,
                                          std::vector<Frame>& out) {
  if (verb == "status") return "ok " + status_line(drive);
  if (verb == "mute") {
    drive.set_mute(true);
    return "ok muted";
  }
  if (verb == "unmute") {
    drive.set_mute(false);
    return "ok answering";
  }
  if (verb == "clear") {
    drive.clear_switches();
    return "ok switches cleared";
  }
  if (verb == "bus-off") {
    drive.go_bus_off(now, out);
    return "ok bus-off";
  }
  return std::nullopt;
}

}  // namespace

std::string status_line(const SimulatedDrive& d) {
  char force[32];
  std::snprintf(force, sizeof force, "%.6g", d.applied_force());
  const DriveCounters& c = d.counters();
  std::string line = "state=\"" + std::string(state_name(d.state())) +
                     "\" nmt=" + std::string(nmt_state_name(d.nmt_state())) + " force=" + force +
                     " syncs=" + std::to_string(c.syncs) + " tpdos=" + std::to_string(c.tpdos_sent) +
                     " rpdos=" + std::to_string(c.rpdos_received) + " emcys=" + std::to_string(c.emcys_sent) +
                     " heartbeat_timeouts=" + std::to_string(c.heartbeat_timeouts) +
                     (d.muted() ? " muted" : "");
  if (!d.fault_reason().empty()) line += " fault=\"" + d.fault_reason() + "\"";
  return line;
}

std::string apply_command(SimulatedDrive& drive, const std::string& line, Micros now,
                          std::vector<Frame>& out) {
  std::istringstream in(line);
  Words words;
  for (std::string w; in >> w;) words.push_back(w);
  if (words.empty()) return error("empty command");
  const std::string& verb = words[0];
  const std::size_t n = words.size();
  if (n == 1) {
    if (auto reply = switch_command(drive, verb, now, out)) return *reply;
  }
  if (verb == "fault" && (n == 2 || n == 3)) return fault_command(drive, words, now, out);
  if (verb == "drop-tpdo" && n == 2) return drop_tpdo_command(drive, words);
  if (verb == "sdo-abort" && n == 3) return sdo_abort_command(drive, words);
  if (verb == "position-jump" && n == 2) return position_jump_command(drive, words);
  if (verb == "refuse-mode" && n == 2 && (words[1] == "on" || words[1] == "off")) {
    drive.refuse_mode(words[1] == "on");
    return "ok refuse-mode " + words[1];
  }
  return error("unknown command '" + line + "'");
}

}  // namespace hapticd::drivers::canopen::sim
