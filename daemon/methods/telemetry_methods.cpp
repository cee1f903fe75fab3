// [telemetry]: UDP datagrams in PlotJuggler's JSON format (docs/config.md),
// and the methods telemetry.get and telemetry.set (docs/protocol.md).

#include <algorithm>
#include <iostream>

#include "daemon/methods/method_support.hpp"
#include "daemon/service.hpp"
#include "daemon/telemetry/datagram.hpp"
#include "world/text.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;
using methods::names_of;

namespace {

[[noreturn]] void invalid(const std::string& member, const std::string& message) {
  throw RpcError(code::invalid_params, "telemetry.set: " + member + " " + message, json{{"member", member}});
}

using world::text::join;

std::string number_text(double value) {
  return world::text::format_significant(value, world::text::precision::message);
}

/// The member as the channel list it must be; names checked against the scene.
std::vector<std::string> channels_member(const json& value, const std::vector<std::string>& scene_channels) {
  if (!value.is_array())
    invalid("channels", "must be an array of channel names ([] for the recording's columns)");
  std::vector<std::string> out;
  for (const auto& entry : value) {
    if (!entry.is_string())
      invalid("channels", "must hold only strings (channel names); got " + entry.dump());
    const auto name = entry.get<std::string>();
    if (std::find(out.begin(), out.end(), name) != out.end())
      invalid("channels", "names '" + name + "' twice");
    out.push_back(name);
  }
  if (const auto unknown = telemetry::unknown_channel(out, scene_channels)) {
    invalid("channels", "names '" + *unknown + "', not a channel of the loaded scene; accepted: " +
                            join(telemetry::available_channels(scene_channels)));
  }
  return out;
}

}  // namespace

void Service::check_telemetry_config() const {
  const auto& t = options_.config.telemetry;
  const auto scene_channels = names_of(initial_.plan.channels);
  for (std::size_t i = 0; i < t.channels.size(); ++i) {
    if (telemetry::unknown_channel({t.channels[i]}, scene_channels)) {
      throw config::ConfigError(
          i < t.channel_where.size() ? t.channel_where[i] : t.channels_where, "telemetry.channels",
          "telemetry.channels names \"" + t.channels[i] + "\", not a channel of scene " +
              initial_.plan.scene + "; accepted: " + join(telemetry::available_channels(scene_channels)));
    }
  }
}

// After start_recorder(): the recorder feeds it (and stops before it).
bool Service::start_telemetry() {
  const auto& cfg = options_.config;
  telemetry::Settings settings;
  if (!cfg.telemetry.udp.empty()) settings.udp = telemetry::parse_endpoint(cfg.telemetry.udp);
  settings.enabled = settings.udp.has_value();
  settings.rate_hz = cfg.telemetry.rate_hz;
  settings.channels = cfg.telemetry.channels;
  settings.batch = cfg.telemetry.batch;
  settings.prefix = cfg.telemetry.prefix;
  telemetry_ = std::make_unique<telemetry::UdpTelemetry>(cfg.loop.period_s);
  // The first scene's names from cycle 0; adopt() moves them on with each scene.
  telemetry_->set_scene(names_of(initial_.plan.channels), 0);
  try {
    telemetry_->apply(settings);
  } catch (const telemetry::TelemetryError& e) {
    std::cerr << "hapticd: telemetry: " << e.what() << "\n";
    return false;
  }
  // Fed on the recorder thread from every drained batch: no second consumer
  // of the RT ring, and nothing on the RT thread.
  recorder_->add_stream(
      [sender = telemetry_.get()](std::span<const TelemetrySample> batch) { sender->offer(batch); });
  return true;
}

void Service::stop_telemetry() {
  if (!telemetry_) return;
  telemetry_->stop();
  const auto c = telemetry_->counters();
  if (c.samples_queued + c.dropped_queue > 0) {
    std::cout << "hapticd: telemetry: " << c.samples_sent << " samples sent in " << c.datagrams_sent
              << " datagrams, " << c.dropped_queue + c.samples_dropped_send << " dropped (queue full "
              << c.dropped_queue << ", send failed " << c.samples_dropped_send << "), " << c.non_finite
              << " non-finite values sent as null" << std::endl;
  }
  telemetry_.reset();
}

json Service::telemetry_counters_json() const {
  if (!telemetry_) return json::object();
  const auto c = telemetry_->counters();
  return {{"samples_queued", c.samples_queued},
          {"samples_sent", c.samples_sent},
          {"datagrams_sent", c.datagrams_sent},
          {"dropped", c.dropped_queue + c.samples_dropped_send},
          {"dropped_queue", c.dropped_queue},
          {"dropped_send", c.samples_dropped_send},
          {"datagrams_dropped", c.datagrams_dropped},
          {"buffer_full", c.buffer_full},
          {"refused", c.refused},
          {"non_finite", c.non_finite},
          {"last_error", c.last_error}};
}

json Service::telemetry_json() const {
  const auto s = telemetry_->settings();
  const CurrentScene scene = current_scene();
  const auto scene_channels = names_of(scene.channels);
  const bool rotary = model_.info.motion == drivers::Motion::rotary;
  json available = json::array();
  for (const auto& name : telemetry::available_channels(scene_channels)) {
    std::string unit;
    if (name == "position") unit = rotary ? "rad" : "m";
    if (name == "command" || name == "applied") unit = rotary ? "N m" : "N";
    if (name == "latency_s" || name == "compute_s" || name == "time_s") unit = "s";
    for (const auto& c : scene.channels) {
      if (c.name == name) unit = c.unit;
    }
    available.push_back({{"name", name}, {"unit", unit}});
  }
  const auto every = telemetry_->decimation();
  json sending = json::array();
  for (const auto& f : telemetry::make_layout(s.channels, scene_channels)) sending.push_back(f.name);
  const auto& configured = options_.config.telemetry.udp;
  return {{"enabled", s.enabled && s.udp.has_value()},
          {"udp", s.udp ? json(s.udp->text) : json(nullptr)},
          {"configured_udp", configured.empty() ? json(nullptr) : json(configured)},
          {"rate_hz", s.rate_hz},
          {"decimation", every},
          {"effective_rate_hz", 1.0 / (static_cast<double>(every) * options_.config.loop.period_s)},
          {"channels", s.channels},
          {"sending", sending},
          {"available", available},
          {"batch", s.batch},
          {"prefix", s.prefix},
          {"time_field", "t"},
          {"max_datagram_bytes", telemetry::max_datagram_bytes},
          {"counters", telemetry_counters_json()}};
}

void Service::register_telemetry_methods(control::ControlServer& server) {
  server.register_method(
      "telemetry.get", [this](const json&, const PeerInfo&) { return telemetry_json(); }, Access::read);

  // Write access: it points the daemon's datagrams somewhere. Only loopback or
  // the address the config names: a client cannot send them off the host.
  server.register_method(
      "telemetry.set",
      {{"enabled", rpc::ParamType::boolean},
       {"udp", rpc::ParamType::string},
       {"rate_hz", rpc::ParamType::number},
       {"channels", rpc::ParamType::array},
       {"batch", rpc::ParamType::integer},
       {"prefix", rpc::ParamType::string}},
      [this](const json& params, const PeerInfo&) {
        telemetry::Settings next = telemetry_->settings();
        const double loop_rate = 1.0 / options_.config.loop.period_s;
        if (params.contains("udp")) {
          const auto& v = params["udp"];
          const std::string accepted =
              "a loopback address (" + std::string(telemetry::endpoint_syntax()) + ")" +
              (options_.config.telemetry.udp.empty() ? std::string()
                                                     : " or the configured " + options_.config.telemetry.udp);
          if (!v.is_string()) invalid("udp", "must be a string; accepted: " + accepted);
          auto endpoint = telemetry::parse_endpoint(v.get<std::string>());
          if (!endpoint)
            invalid("udp", "\"" + v.get<std::string>() + "\" is not an address; accepted: " + accepted);
          const auto configured = telemetry::parse_endpoint(options_.config.telemetry.udp);
          if (!endpoint->loopback && !(configured && *configured == *endpoint)) {
            invalid("udp", "\"" + endpoint->text +
                               "\" is neither loopback nor the address the config names (telemetry is "
                               "unauthenticated); accepted: " +
                               accepted);
          }
          next.udp = std::move(endpoint);
          next.enabled = true;
        }
        if (params.contains("enabled")) {
          if (!params["enabled"].is_boolean()) invalid("enabled", "must be true or false");
          next.enabled = params["enabled"].get<bool>();
        }
        if (params.contains("rate_hz")) {
          const auto& v = params["rate_hz"];
          const std::string range = "from 0.1 to " + number_text(loop_rate) + " (the loop rate)";
          if (!v.is_number()) invalid("rate_hz", "must be a number of samples per second " + range);
          const double hz = v.get<double>();
          if (!(hz >= telemetry::min_rate_hz && hz <= loop_rate * (1.0 + 1e-9)))
            invalid("rate_hz", "= " + v.dump() + " is out of range; accepted: " + range);
          next.rate_hz = hz;
        }
        if (params.contains("channels"))
          next.channels = channels_member(params["channels"], names_of(current_scene().channels));
        if (params.contains("batch")) {
          const auto& v = params["batch"];
          if (!v.is_number_integer() || v.get<std::int64_t>() < 1 ||
              v.get<std::int64_t>() > static_cast<std::int64_t>(telemetry::max_batch))
            invalid("batch", "must be an integer from 1 to 64 (samples per datagram); got " + v.dump());
          next.batch = static_cast<std::uint32_t>(v.get<std::int64_t>());
        }
        if (params.contains("prefix")) {
          const auto& v = params["prefix"];
          if (!v.is_string() || !telemetry::valid_prefix(v.get<std::string>()))
            invalid("prefix", "must be 1 to 32 of the characters A-Z a-z 0-9 _ -; got " + v.dump());
          next.prefix = v.get<std::string>();
        }
        if (next.enabled && !next.udp)
          invalid("enabled", "needs an address: give udp (no [telemetry] udp is configured)");
        try {
          telemetry_->apply(next);
        } catch (const telemetry::TelemetryError& e) {
          throw RpcError(code::refused, std::string("telemetry.set: ") + e.what());
        }
        return telemetry_json();
      },
      Access::write);
}

}  // namespace hapticd::daemon
