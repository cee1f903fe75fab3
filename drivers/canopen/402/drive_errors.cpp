#include "drivers/canopen/402/drive_errors.hpp"

#include <cstdio>
#include <utility>

namespace hapticd::drivers::canopen::cia402 {
namespace {

// Drive error codes (CiA 402-2 / IEC 61800-7-201 annex), in our words.
constexpr std::pair<std::uint16_t, std::string_view> drive_codes[] = {
    {0x2110, "short circuit or earth leakage (input)"},
    {0x2120, "earth leakage (input)"},
    {0x2130, "short circuit (input)"},
    {0x2213, "over-current in ramp function"},
    {0x2214, "over-current in the sequence"},
    {0x2220, "continuous over current (device internal)"},
    {0x2230, "short circuit or earth leakage (device internal)"},
    {0x2240, "earth leakage (device internal)"},
    {0x2250, "short circuit (device internal)"},
    {0x2310, "continuous over current (motor side)"},
    {0x2320, "short circuit or earth leakage (motor side)"},
    {0x2330, "earth leakage (motor side)"},
    {0x2331, "earth leakage phase U"},
    {0x2332, "earth leakage phase V"},
    {0x2333, "earth leakage phase W"},
    {0x2340, "short circuit (motor side)"},
    {0x2341, "short circuit phases U-V"},
    {0x2342, "short circuit phases V-W"},
    {0x2343, "short circuit phases W-U"},
    {0x3110, "mains over-voltage"},
    {0x3120, "mains under-voltage"},
    {0x3130, "mains phase failure"},
    {0x3134, "mains phase sequence"},
    {0x3140, "mains frequency"},
    {0x3141, "mains frequency too high"},
    {0x3142, "mains frequency too low"},
    {0x3210, "DC link over-voltage"},
    {0x3220, "DC link under-voltage"},
    {0x3230, "load error"},
    {0x3310, "output over-voltage"},
    {0x3320, "armature circuit"},
    {0x3321, "armature circuit interrupted"},
    {0x3330, "field circuit"},
    {0x3331, "field circuit interrupted"},
    {0x4110, "excess ambient temperature"},
    {0x4120, "too low ambient temperature"},
    {0x4130, "supply air temperature"},
    {0x4140, "air outlet temperature"},
    {0x4210, "excess device temperature"},
    {0x4220, "too low device temperature"},
    {0x4300, "drive temperature"},
    {0x4310, "excess drive temperature"},
    {0x4320, "too low drive temperature"},
    {0x4400, "supply temperature"},
    {0x4410, "excess supply temperature"},
    {0x4420, "too low supply temperature"},
    {0x5100, "supply"},
    {0x5110, "supply low voltage"},
    {0x5111, "supply +/-15 V"},
    {0x5112, "supply +24 V"},
    {0x5113, "supply +5 V"},
    {0x5120, "supply intermediate circuit"},
    {0x5200, "control"},
    {0x5210, "measurement circuit"},
    {0x5220, "computing circuit"},
    {0x5300, "operating unit"},
    {0x5400, "power section"},
    {0x5410, "output stages"},
    {0x5420, "chopper"},
    {0x5430, "input stages"},
    {0x5440, "contacts"},
    {0x5450, "fuses"},
    {0x5500, "data storage"},
    {0x5510, "RAM"},
    {0x5520, "EPROM"},
    {0x5530, "EEPROM"},
    {0x6010, "software reset (watchdog)"},
    {0x6310, "loss of parameters"},
    {0x6320, "parameter error"},
    {0x7110, "brake chopper"},
    {0x7111, "brake chopper failure"},
    {0x7112, "brake chopper over current"},
    {0x7113, "brake chopper protective circuit"},
    {0x7120, "motor"},
    {0x7121, "motor blocked"},
    {0x7122, "motor error or commutation malfunction"},
    {0x7123, "motor tilted"},
    {0x7200, "measurement circuit"},
    {0x7300, "sensor"},
    {0x7301, "tacho fault"},
    {0x7302, "tacho wrong polarity"},
    {0x7303, "resolver 1 fault"},
    {0x7304, "resolver 2 fault"},
    {0x7305, "incremental sensor 1 fault"},
    {0x7306, "incremental sensor 2 fault"},
    {0x7307, "incremental sensor 3 fault"},
    {0x7310, "speed"},
    {0x7320, "position"},
    {0x7400, "computation circuit"},
    {0x7500, "communication"},
    {0x7510, "serial interface no. 1"},
    {0x7520, "serial interface no. 2"},
    {0x7600, "data storage (external)"},
    {0x8300, "torque control"},
    {0x8311, "excess torque"},
    {0x8312, "difficult start up"},
    {0x8313, "standstill torque"},
    {0x8321, "insufficient torque"},
    {0x8331, "torque fault"},
    {0x8400, "velocity speed controller"},
    {0x8500, "position controller"},
    {0x8600, "positioning controller"},
    {0x8611, "following error"},
    {0x8612, "reference limit"},
    {0x8700, "sync controller"},
    {0x8800, "winding controller"},
    {0x9000, "external error"},
    {0xF001, "deceleration"},
    {0xF002, "sub-synchronous run"},
    {0xF003, "stroke operation"},
    {0xF004, "control"},
};

std::string hex(unsigned value, int digits) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%0*X", digits, value);
  return text;
}

}  // namespace

std::string describe_error_code(std::uint16_t code) {
  for (const auto& [c, words] : drive_codes)
    if (c == code) return std::string(words);
  const auto communication = cia301::describe_communication_error(code);
  const bool class_only =
      communication && (*communication == "communication" || *communication == "protocol error");
  if (communication && !class_only) return std::string(*communication);
  const std::string_view group = class_only ? *communication : cia301::error_class(code);
  return std::string(group) + ": code " + hex(code, 4) + " not defined by CiA 301/402";
}

std::string describe_emergency(const cia301::Emergency& emcy) {
  std::string line = "EMCY " + hex(emcy.error_code, 4) + ": " + describe_error_code(emcy.error_code) +
                     "; error register " + hex(emcy.error_register, 2) + " (" +
                     cia301::describe_error_register(emcy.error_register) + "); manufacturer bytes";
  for (const std::uint8_t b : emcy.manufacturer) {
    char text[4];
    std::snprintf(text, sizeof text, " %02X", static_cast<unsigned>(b));
    line += text;
  }
  return line;
}

}  // namespace hapticd::drivers::canopen::cia402
