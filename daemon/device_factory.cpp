#include "daemon/device_factory.hpp"

#include <charconv>
#include <stdexcept>

#include "drivers/loopback/parameter_error.hpp"

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

const config::Parameter* given(const config::ParameterList& list, std::string_view key) {
  for (const auto& p : list) {
    if (p.key == key) return &p;
  }
  return nullptr;
}

/// A refused [device.loopback] key as a config error, at its value's position
/// (else at the table). ParameterError names the key; other errors name none.
config::ConfigError device_error(const config::DeviceConfig& device, const std::invalid_argument& error) {
  const auto* refused = dynamic_cast<const drivers::loopback::ParameterError*>(&error);
  if (refused != nullptr) {
    if (const auto* p = given(device.parameters, refused->key())) {
      return {p->where, "device.loopback." + p->key, error.what()};
    }
  }
  return {device.table_where, "device.loopback", error.what()};
}

/// A refused hand script as a config error. Its keys come from
/// [device.loopback.hand] (flattened to "hand.<key>") or from one
/// `hand = "key=value ..."` string: point at the key at fault, else at that
/// string, else at the first hand key (a missing key has no position).
config::ConfigError hand_error(const config::DeviceConfig& device, const std::invalid_argument& error) {
  const auto* refused = dynamic_cast<const drivers::loopback::ParameterError*>(&error);
  const config::Parameter* p = nullptr;
  if (refused != nullptr) p = given(device.parameters, "hand." + refused->key());
  if (p == nullptr) p = given(device.parameters, "hand");
  for (const auto& q : device.parameters) {
    if (p == nullptr && q.key.starts_with("hand.")) p = &q;
  }
  if (p == nullptr) return {device.table_where, "device.loopback.hand", error.what()};
  return {p->where, "device.loopback." + p->key, error.what()};
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
    throw device_error(device, e);
  }
  drivers::loopback::HandScript hand;
  if (!hand_text.empty()) {
    try {
      hand = drivers::loopback::parse_hand_script(hand_text);
    } catch (const std::invalid_argument& e) {
      throw hand_error(device, e);
    }
  }
  auto loopback = std::make_unique<drivers::loopback::LoopbackDevice>(loopback_config, hand);
  BuiltDevice built;
  built.loopback = loopback.get();
  built.device = std::move(loopback);
  return built;
}

}  // namespace hapticd::daemon
