// Fuzz target: the loopback's hand-script parser (hand.set, [device.loopback]
// hand = "..."). A script it accepts must print back (to_text) as one that
// parses to the same script; one it refuses must say why.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "drivers/simulation/hand_script.hpp"

namespace simulation = hapticd::drivers::simulation;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::string error;
  const auto script = simulation::try_parse_hand_script(text, error);
  if (!script) {
    if (error.empty()) __builtin_trap();
    return 0;
  }
  std::string again_error;
  const auto again = simulation::try_parse_hand_script(script->to_text(), again_error);
  if (!again || !(*again == *script)) __builtin_trap();
  // The trajectory is evaluated every period on the RT thread: finite in, finite out.
  for (const double t : {0.0, 0.5, 1e3}) {
    const auto sample = script->trajectory.at_time(t);
    if (!std::isfinite(sample.position) || !std::isfinite(sample.velocity)) __builtin_trap();
  }
  return 0;
}
