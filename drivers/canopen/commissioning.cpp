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

std::optional<std::string> refused_while_enabled(cia301::ObjectAddress a) {
  const std::string object = cia301::to_string(a);
  if (const auto pdo = cia301::pdo_of_index(a.index))
    return object + " is a PDO " + (pdo->mapping ? "mapping" : "communication") +
           " parameter: changing it changes the cyclic exchange";
  switch (a.index) {
    case cia402::object::modes_of_operation:
      return object + " is the mode of operation the cyclic exchange runs in";
    case cia402::object::controlword:
      return object + " is the controlword, which RPDO1 sends every period";
    case cia402::object::interpolation_time_period:
      return object + " is the interpolation period, which must equal the loop period";
    case cia301::object::cob_id_sync:
    case cia301::object::communication_cycle_period:
      return object + " is a SYNC setting of the cyclic exchange";
    case cia301::object::consumer_heartbeat_time:
    case cia301::object::producer_heartbeat_time:
    case cia402::object::abort_connection_option:
      return object + " is part of the dead-man that stops the drive when hapticd dies";
    default:
      return std::nullopt;
  }
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

}  // namespace hapticd::drivers::canopen
