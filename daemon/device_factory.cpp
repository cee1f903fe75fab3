#include "daemon/device_factory.hpp"

#include <charconv>
#include <stdexcept>

namespace hapticd::daemon {

namespace {

std::string as_text(const config::ParameterValue& value) {
  if (const auto* d = std::get_if<double>(&value)) {
    char buffer[32];  // shortest round-trip text
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, *d);
    return {buffer, ec == std::errc{} ? end : buffer};
  }
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return std::get<std::string>(value);
}

/// The position to blame for a driver's one-line error: the first parameter
/// whose key the message names, else the [device] table.
config::SourcePosition blame(const config::DeviceConfig& device, const std::string& message) {
  for (const auto& p : device.parameters) {
    if (message.find(p.key) != std::string::npos) return p.where;
  }
  return device.driver_where;
}

}  // namespace

BuiltDevice build_device(const config::DaemonConfig& config) {
  const auto& device = config.device;
  if (device.driver != "loopback") {
    throw config::ConfigError(
        device.driver_where, "device.driver",
        "driver '" + device.driver + "' is not built in this version of hapticd; accepted: loopback");
  }
  std::vector<std::pair<std::string, std::string>> pairs;
  std::string hand_text;
  for (const auto& p : device.parameters) {
    // [device.loopback.hand] keys arrive flattened as "hand.<key>"; a plain
    // `hand = "mode=hold ..."` string is accepted too.
    if (p.key == "hand") {
      hand_text += as_text(p.value) + " ";
    } else if (p.key.starts_with("hand.")) {
      hand_text += p.key.substr(5) + "=" + as_text(p.value) + " ";
    } else {
      pairs.emplace_back(p.key, as_text(p.value));
    }
  }
  pairs.emplace_back("period", as_text(config.loop.period_s));
  drivers::loopback::LoopbackConfig loopback_config;
  try {
    loopback_config = drivers::loopback::parse_loopback_config(pairs);
  } catch (const std::invalid_argument& e) {
    throw config::ConfigError(blame(device, e.what()), "device.loopback", e.what());
  }
  drivers::loopback::HandScript hand;
  if (!hand_text.empty()) {
    try {
      hand = drivers::loopback::parse_hand_script(hand_text);
    } catch (const std::invalid_argument& e) {
      throw config::ConfigError(blame(device, e.what()), "device.loopback.hand", e.what());
    }
  }
  auto loopback = std::make_unique<drivers::loopback::LoopbackDevice>(loopback_config, hand);
  BuiltDevice built;
  built.loopback = loopback.get();
  built.device = std::move(loopback);
  return built;
}

}  // namespace hapticd::daemon
