#include "drivers/canopen/commissioning.hpp"

#include <charconv>
#include <stdexcept>

#include "drivers/canopen/301/pdo.hpp"
#include "drivers/canopen/402/objects.hpp"

namespace hapticd::drivers::canopen {

namespace {

std::uint32_t parse_number(const std::string& text, std::uint32_t max, const char* what) {
  std::string_view s = text;
  int base = 10;
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
    s.remove_prefix(2);
    base = 16;
  }
  std::uint32_t value = 0;
  const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value, base);
  if (s.empty() || error != std::errc() || end != s.data() + s.size() || value > max)
    throw std::invalid_argument(std::string(what) + " '" + text + "' is not a number 0.." +
                                std::to_string(max) + " (decimal, or hex with 0x)");
  return value;
}

}  // namespace

namespace {

/// An object (or a range) whose value changes the meaning or the bound of
/// what hapticd sends (RPDO1's torque, the SYNC, the heartbeat) or reads
/// (TPDO1's position, the EMCY, the drive's heartbeat): CiA 301 / CiA 402.
struct GuardedObject {
  std::uint16_t first, last;
  const char* name;
  const char* role;
};

constexpr GuardedObject guarded[] = {
    {0x1005, 0x1005, "COB-ID SYNC", "the identifier of the SYNC hapticd sends every period"},
    {0x1006, 0x1006, "communication cycle period", "the SYNC period the drive expects"},
    {0x1007, 0x1007, "synchronous window length", "PDOs outside the window are discarded"},
    {0x1011, 0x1011, "restore default parameters",
     "brings back the drive's default mapping, units and limits"},
    {0x1014, 0x1014, "COB-ID EMCY", "where the drive reports its faults to hapticd"},
    {0x1015, 0x1015, "inhibit time EMCY", "how long the drive may hold back a fault report"},
    {0x1016, 0x1016, "consumer heartbeat time", "the dead-man that stops the drive when hapticd dies"},
    {0x1017, 0x1017, "producer heartbeat time", "the heartbeat by which hapticd watches the drive"},
    {0x1019, 0x1019, "synchronous counter overflow value", "the form of the SYNC hapticd sends (no counter)"},
    {0x1029, 0x1029, "error behaviour",
     "what the drive does on a communication error (the dead-man's NMT reaction)"},
    {0x2000, 0x5FFF, "manufacturer-specific object",
     "hapticd cannot know whether it scales or bounds the torque"},
    {0x6007, 0x6007, "abort connection option code", "what the drive does when hapticd's heartbeat stops"},
    {0x6040, 0x6040, "controlword", "sent by hapticd in RPDO1 every period"},
    {0x605A, 0x605A, "quick stop option code", "how the drive stops on a quick stop"},
    {0x605B, 0x605B, "shutdown option code", "how the drive stops on hapticd's Shutdown"},
    {0x605C, 0x605C, "disable operation option code", "how the drive stops on hapticd's Disable Operation"},
    {0x605D, 0x605D, "halt option code",
     "how the drive stops on the halt bit hapticd sets without a valid command"},
    {0x605E, 0x605E, "fault reaction option code", "how the drive stops on a fault"},
    {0x6060, 0x6060, "modes of operation",
     "hapticd's torque is a torque only in cyclic synchronous torque (10)"},
    {0x6071, 0x6071, "target torque", "sent by hapticd in RPDO1 every period"},
    {0x6072, 0x6072, "max torque", "the drive's bound on every torque hapticd sends"},
    {0x6073, 0x6073, "max current", "the drive's bound on the motor current, so on the torque"},
    {0x6075, 0x6075, "motor rated current", "the unit of 0x6073 max current"},
    {0x6076, 0x6076, "motor rated torque", "the scale of every torque hapticd sends"},
    {0x607C, 0x607C, "home offset",
     "shifts the position hapticd reads: a jump the scene would answer with torque"},
    {0x607E, 0x607E, "polarity", "the sign of the position and velocity hapticd reads"},
    {0x6080, 0x6080, "max motor speed", "the drive's bound on the speed its torque may reach"},
    {0x608F, 0x608F, "position encoder resolution", "the unit of the position hapticd reads"},
    {0x6090, 0x6090, "velocity encoder resolution", "the unit of the velocity hapticd reads"},
    {0x6091, 0x6091, "gear ratio", "the unit of the position hapticd reads"},
    {0x6092, 0x6092, "feed constant", "the unit of the position hapticd reads"},
    {0x6093, 0x6093, "position factor", "the unit of the position hapticd reads"},
    {0x6094, 0x6096, "velocity factor", "the unit of the velocity hapticd reads"},
    {0x60A8, 0x60A8, "SI unit position", "the unit of the position hapticd reads"},
    {0x60A9, 0x60A9, "SI unit velocity", "the unit of the velocity hapticd reads"},
    {0x60B2, 0x60B2, "torque offset", "added to every torque hapticd sends (cyclic synchronous torque)"},
    {0x60C2, 0x60C2, "interpolation time period", "must equal hapticd's loop period"},
    {0x60E0, 0x60E0, "positive torque limit value", "the drive's bound on the torque hapticd sends"},
    {0x60E1, 0x60E1, "negative torque limit value", "the drive's bound on the torque hapticd sends"},
};

std::string pdo_role(const cia301::PdoRef& pdo) {
  const bool rx = pdo.direction == cia301::PdoDirection::receive;
  const std::string name = std::string(rx ? "RPDO" : "TPDO") + std::to_string(pdo.number) +
                           (pdo.mapping ? " mapping parameter" : " communication parameter");
  if (rx)
    return name + (pdo.mapping ? ": what the bytes of hapticd's torque command mean"
                               : ": how hapticd's torque command reaches the drive");
  return name + (pdo.mapping ? ": what the bytes of the position hapticd reads mean"
                             : ": how the position hapticd reads leaves the drive");
}

}  // namespace

std::optional<std::string> guarded_role(std::uint16_t index) {
  if (const auto pdo = cia301::pdo_of_index(index)) return pdo_role(*pdo);
  for (const GuardedObject& g : guarded)
    if (index >= g.first && index <= g.last) return std::string(g.name) + ": " + g.role;
  return std::nullopt;
}

std::optional<std::string> refused_while_enabled(cia301::ObjectAddress a) {
  const auto role = guarded_role(a.index);
  if (!role) return std::nullopt;
  return cia301::to_string(a) + " " + *role +
         "; refused while the drive is enabled, disable it first (hapticd keeps it enabled while it runs)";
}

cia301::DataType write_type(cia301::ObjectAddress address, std::optional<cia301::DataType> given) {
  const auto info = cia402::find_standard_object(address);
  if (!info) {
    if (!given)
      throw std::invalid_argument(cia301::to_string(address) +
                                  " is not an object this driver knows: give its type (accepted: " +
                                  std::string(cia301::accepted_data_type_names()) + ")");
    return *given;
  }
  if (given && cia301::size_of(*given) != cia301::size_of(info->type))
    throw std::invalid_argument(cia301::to_string(address) + " (" + std::string(info->name) + ") is " +
                                std::string(cia301::short_name(info->type)) + ", not " +
                                std::string(cia301::short_name(*given)));
  return given.value_or(info->type);
}

std::uint16_t parse_index(const std::string& text) {
  return static_cast<std::uint16_t>(parse_number(text, 0xFFFF, "index"));
}

std::uint8_t parse_sub_index(const std::string& text) {
  return static_cast<std::uint8_t>(parse_number(text, 0xFF, "sub-index"));
}

SdoAccess describe_access(cia301::ObjectAddress address, std::uint32_t raw,
                          std::optional<cia301::DataType> type) {
  SdoAccess a;
  a.address = address;
  a.raw = raw;
  const auto info = cia402::find_standard_object(address);
  a.type = type ? type : info ? std::optional(info->type) : std::nullopt;
  a.value = a.type ? cia301::from_raw(*a.type, raw) : static_cast<std::int64_t>(raw);
  a.name = info ? std::string(info->name) : "";
  return a;
}

}  // namespace hapticd::drivers::canopen
