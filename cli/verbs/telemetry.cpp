// hapticctl telemetry [on|off] [udp=ADDR:PORT] [rate_hz=HZ] [channels=a,b,...]
//                     [batch=N] [prefix=NAME]
// UDP telemetry for PlotJuggler: without arguments the settings in force and
// the counters (telemetry.get); with any, telemetry.set.

#include <iostream>
#include <sstream>

#include "cli/verbs.hpp"

namespace hapticctl {

namespace {

/// "a,b,c" -> ["a","b","c"]; "" -> [] (the recording's columns).
nlohmann::json channel_list(const nlohmann::json& value) {
  nlohmann::json out = nlohmann::json::array();
  if (!value.is_string()) {
    std::cerr << "hapticctl: telemetry: channels= takes names separated by commas, e.g. "
                 "channels=position,applied (empty: the recording's columns)\n";
    throw Exit(exit_code::usage);
  }
  std::stringstream in(value.get<std::string>());
  std::string name;
  while (std::getline(in, name, ',')) {
    if (!name.empty()) out.push_back(name);
  }
  return out;
}

nlohmann::json telemetry_params(const std::vector<std::string>& words) {
  std::vector<std::string> assignments;
  nlohmann::json params = nlohmann::json::object();
  for (std::size_t i = 0; i < words.size(); ++i) {
    if (i == 0 && (words[i] == "on" || words[i] == "off")) {
      params["enabled"] = words[i] == "on";
    } else {
      assignments.push_back(words[i]);
    }
  }
  const nlohmann::json given = detail::assignments(assignments);
  for (const auto& [key, value] : given.items()) {
    // An address is a string even where it would parse as something else.
    if (key == "channels") {
      params[key] = channel_list(value);
    } else if (key == "udp" || key == "prefix") {
      params[key] = value.is_string() ? value : nlohmann::json(value.dump());
    } else {
      params[key] = value;
    }
  }
  return params;
}

void print_telemetry(const nlohmann::json& t) {
  std::cout << "telemetry: " << (t.value("enabled", false) ? "on" : "off");
  if (!t["udp"].is_null())
    std::cout << ", to " << t["udp"].get<std::string>() << " (UDP, JSON, unauthenticated)";
  std::cout << "\n  rate: " << detail::scalar(t["effective_rate_hz"]) << " Hz (every "
            << detail::scalar(t["decimation"]) << " cycles; asked " << detail::scalar(t["rate_hz"]) << " Hz)"
            << "\n  batch: " << detail::scalar(t["batch"]) << " samples per datagram (at most "
            << detail::scalar(t["max_datagram_bytes"]) << " bytes)"
            << "\n  series: /" << t.value("prefix", std::string()) << "/<channel> against field \""
            << t.value("time_field", std::string("t")) << "\" (s, cycle x period)\n  sending:";
  for (const auto& c : t["sending"]) std::cout << ' ' << c.get<std::string>();
  std::cout << "\n  available:";
  for (const auto& c : t["available"]) {
    std::cout << ' ' << c["name"].get<std::string>();
    if (!c["unit"].get<std::string>().empty()) std::cout << " (" << c["unit"].get<std::string>() << ')';
  }
  std::cout << "\n  counters:\n";
  detail::print_fields(std::cout, t["counters"], 4);
}

}  // namespace

void add_telemetry_command(CLI::App& app, CommonOptions& opts) {
  auto words = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "telemetry",
      "UDP telemetry for PlotJuggler: show it, or [on|off] udp= rate_hz= channels= batch= prefix=");
  add_common_options(*cmd, opts);
  cmd->add_option("settings", *words,
                  "on or off, then name=value: udp=127.0.0.1:9870 (loopback or the configured address), "
                  "rate_hz=HZ, channels=a,b (empty: the recording's columns), batch=N (1-64), prefix=NAME");
  cmd->callback([&opts, words] {
    const bool set = !words->empty();
    auto result = set ? detail::call(opts, "telemetry.set", telemetry_params(*words))
                      : detail::call(opts, "telemetry.get");
    if (opts.json) return detail::print_json(result);
    print_telemetry(result);
  });
}

}  // namespace hapticctl
