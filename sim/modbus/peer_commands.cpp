#include "sim/modbus/peer_commands.hpp"

#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace hapticd::drivers::modbus::sim {

namespace {

constexpr const char* usage =
    "commands: exception CODE [COUNT], timeout [COUNT], crc [COUNT], drop, late MS [COUNT], fault BITS, "
    "position-jump COUNTS, state, help";

// A whole number in [lo, hi], decimal or 0x hex; throws naming `what`.
long number(const std::string& text, const char* what, long lo, long hi) {
  std::size_t used = 0;
  long value = 0;
  try {
    value = std::stol(text, &used, 0);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || value < lo || value > hi)
    throw std::invalid_argument(std::string(what) + " \"" + text + "\" is not a whole number in " +
                                std::to_string(lo) + ".." + std::to_string(hi));
  return value;
}

}  // namespace

std::string state_json(const AmplifierState& s) {
  char text[512];
  std::snprintf(text, sizeof text,
                "{\"enabled\":%s,\"fault\":%u,\"torque\":%.17g,\"torque_counts\":%d,\"steps\":%llu,"
                "\"requests\":%llu,\"watchdog_armed\":%s,\"watchdog_trips\":%llu,\"resets\":%llu,"
                "\"trip_silence_s\":%.6f,\"watchdog_register\":%u,\"alive_jumps\":%llu}",
                s.enabled ? "true" : "false", static_cast<unsigned>(s.fault), s.applied_torque,
                static_cast<int>(s.torque_counts), static_cast<unsigned long long>(s.steps),
                static_cast<unsigned long long>(s.requests), s.watchdog_armed ? "true" : "false",
                static_cast<unsigned long long>(s.watchdog_trips), static_cast<unsigned long long>(s.resets),
                s.trip_silence_s, static_cast<unsigned>(s.watchdog_register),
                static_cast<unsigned long long>(s.alive_jumps));
  return text;
}

std::string run_peer_command(const std::string& line, AmplifierServer& server, Amplifier& amplifier) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  if (words.empty()) return "error: empty command; " + std::string(usage);
  const std::string& verb = words[0];
  auto count_at = [&](std::size_t i) {
    return words.size() > i ? static_cast<int>(number(words[i], "COUNT", 1, 1000000)) : 1;
  };
  try {
    if (verb == "exception" && (words.size() == 2 || words.size() == 3)) {
      const auto code = static_cast<std::uint8_t>(number(words[1], "CODE", 1, 255));
      server.inject(Injection::exception, count_at(2), code);
    } else if (verb == "timeout" && words.size() <= 2) {
      server.inject(Injection::timeout, count_at(1));
    } else if (verb == "crc" && words.size() <= 2) {
      server.inject(Injection::crc_error, count_at(1));
    } else if (verb == "drop" && words.size() == 1) {
      server.inject(Injection::drop);
    } else if (verb == "late" && (words.size() == 2 || words.size() == 3)) {
      const int ms = static_cast<int>(number(words[1], "MS", 1, 60000));
      server.inject(Injection::late, count_at(2), 0, ms);
    } else if (verb == "fault" && words.size() == 2) {
      amplifier.inject_fault(static_cast<std::uint16_t>(number(words[1], "BITS", 1, 0xFFFF)));
    } else if (verb == "position-jump" && words.size() == 2) {
      // Either sign, up to a 32-bit counter's whole range.
      const long counts = number(words[1], "COUNTS", -(1L << 32), 1L << 32);
      if (counts == 0) throw std::invalid_argument("COUNTS must not be 0");
      amplifier.jump_position(counts);
    } else if (verb == "state" && words.size() == 1) {
      return "ok " + state_json(amplifier.state());
    } else if (verb == "help") {
      return std::string("ok ") + usage;
    } else {
      return "error: \"" + line + "\" is not a command; " + usage;
    }
  } catch (const std::invalid_argument& e) {
    return std::string("error: ") + e.what();
  }
  return "ok";
}

}  // namespace hapticd::drivers::modbus::sim
