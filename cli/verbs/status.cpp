// hapticctl status: the daemon's state, device, scene and fault, for a
// person (one screen, essentials first), --verbose for every member,
// --json for the daemon's result unchanged.

#include <iostream>
#include <sstream>
#include <vector>

#include "cli/verbs.hpp"
#include "cli/verbs/status_text.hpp"

namespace hapticctl {

using nlohmann::json;

namespace detail {
namespace {

constexpr std::size_t screen_width = 78;
constexpr const char* continuation = "             ";  // under the value column

std::string text_of(const json& object, const char* key, const std::string& otherwise = "") {
  if (!object.is_object() || !object.contains(key)) return otherwise;
  const json& v = object[key];
  if (v.is_null()) return otherwise;
  return scalar(v);
}

/// "name: value" line with the value column aligned; items joined with ", "
/// and wrapped under the value column.
void field(std::ostream& out, const std::string& name, const std::vector<std::string>& items) {
  std::string line = "  " + name + ":";
  line += std::string(line.size() < 13 ? 13 - line.size() : 1, ' ');
  const std::size_t start = line.size();
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string piece = items[i] + (i + 1 < items.size() ? "," : "");
    if (line.size() > start && line.size() + 1 + piece.size() > screen_width) {
      out << line << '\n';
      line = continuation;
    } else if (line.size() > start) {
      line += ' ';
    }
    line += piece;
  }
  out << line << '\n';
}

struct DeviceUnits {
  std::string position;
  std::string force;
};

DeviceUnits units_of(const json& status) {
  const json device = status.value("device", json::object());
  if (device.is_object() && device.value("motion", std::string()) == "linear") return {"m", "N"};
  return {"rad", "N m"};
}

std::string headline(const json& status) {
  std::ostringstream s;
  s << "hapticd " << text_of(status, "version", "?") << ": ";
  const std::string state = text_of(status, "state", "?");
  if (state == "fault") {
    s << "FAULT (" << text_of(status, "fault", "reason not given") << "), output held at zero";
  } else if (state == "stopped") {
    s << "stopped (the RT loop has finished)";
  } else {
    s << state;
    if (status.value("calibration", json::object()).value("output_held", false))
      s << ", output held at zero: not calibrated";
  }
  if (status.contains("time_s")) s << ", " << format_value("time_s", status["time_s"]) << " of loop time";
  if (status.contains("period_s")) {
    s << ", period "
      << microseconds_text(status["period_s"].is_number() ? json(status["period_s"].get<double>() * 1e6)
                                                          : json(nullptr));
  }
  if (status.contains("clock")) s << ", " << text_of(status, "clock") << " clock";
  return s.str();
}

void fault_lines(std::ostream& out, const json& status) {
  if (text_of(status, "state") != "fault") return;
  std::vector<std::string> items{"latched: " + text_of(status, "fault", "?")};
  const json device = status.value("device", json::object());
  if (const std::string said = text_of(device, "fault_reason"); !said.empty()) {
    items.push_back("the device says: " + said);
  }
  items.emplace_back("clear it with `hapticctl fault clear`");
  field(out, "fault", items);
}

void device_lines(std::ostream& out, const json& status, const DeviceUnits& units) {
  const json device = status.value("device", json::object());
  if (!device.is_object() || device.empty()) return;
  std::vector<std::string> items{text_of(device, "driver", "?") + " (" + text_of(device, "motion", "?") +
                                 "), " + text_of(device, "state", "?")};
  if (const std::string d = text_of(device, "description"); !d.empty()) items.push_back(d);
  if (const std::string source = text_of(device, "model_source"); !source.empty()) {
    items.push_back("model from " + source);
  }
  if (status.contains("torque_limit")) {
    items.push_back("torque limit " + text_of(status, "torque_limit") + " " + units.force);
  }
  field(out, "device", items);
}

/// How the device is calibrated (docs/config.md, "Calibration"); nothing
/// from a daemon that does not say.
void calibration_lines(std::ostream& out, const json& status) {
  const json c = status.value("calibration", json::object());
  if (!c.is_object() || c.empty()) return;
  std::vector<std::string> items{text_of(c, "summary", "?")};
  if (c.value("output_held", false))
    items.emplace_back(
        "OUTPUT HELD AT ZERO until calibrated ([device] require_calibration): `hapticctl device zero`");
  if (const std::string note = text_of(c, "note"); !note.empty()) items.push_back(note);
  field(out, "calibration", items);
}

/// "passive" / "not passive" where the daemon reports passivity (a scene's
/// stability or passivity member); "" where it does not.
std::string passivity_words(const json& scene) {
  for (const json* holder : {&scene, scene.contains("stability") ? &scene["stability"] : nullptr,
                             scene.contains("passivity") ? &scene["passivity"] : nullptr}) {
    if (holder == nullptr || !holder->is_object() || !holder->contains("passive")) continue;
    const json& p = (*holder)["passive"];
    if (p.is_boolean()) return p.get<bool>() ? "passive" : "not passive";
  }
  return "";
}

/// The verdict in words (docs/protocol.md, "Stability verdict").
std::string verdict_words(const json& verdict) {
  std::string v = text_of(verdict, "verdict");
  if (v == "marginal") return "marginal (poles on the unit circle: oscillations neither grow nor decay)";
  if (v == "unstable") return "UNSTABLE";
  if (v == "cannot_assess") return "cannot assess: " + text_of(verdict, "reason", "reason not given");
  if (!v.empty()) return v;
  return verdict.is_object() && verdict.value("checked", true) ? "?" : "not checked (no linear model)";
}

void scene_lines(std::ostream& out, const json& status) {
  const json scene = status.value("scene", json::object());
  if (!scene.is_object() || scene.empty()) return;
  std::vector<std::string> items;
  const json parameters = scene.value("parameters", json::object());
  const json units = scene.value("units", json::object());
  for (const auto& [name, value] : parameters.items()) {
    const std::string unit = units.is_object() ? text_of(units, name.c_str()) : "";
    items.push_back(name + " " + scalar(value) + (unit.empty() || !value.is_number() ? "" : " " + unit));
  }
  const std::string name = text_of(scene, "name", "?");
  if (items.empty()) {
    items.push_back(name + " (no parameters)");
  } else {
    items.front() = name + ": " + items.front();
  }
  field(out, "scene", items);
  const json verdict = scene.value("stability", json::object());
  std::vector<std::string> stability{verdict_words(verdict)};
  if (scene.value("forced", false))
    stability.front() = "UNSTABLE, loaded with force (the torque limit still holds)";
  if (const std::string passive = passivity_words(scene); !passive.empty()) stability.push_back(passive);
  if (const std::string summary = text_of(verdict, "summary"); !summary.empty()) stability.push_back(summary);
  if (const json passivity = verdict.is_object() ? verdict.value("passivity", json()) : json();
      passivity.is_object()) {
    if (const std::string summary = text_of(passivity, "summary"); !summary.empty())
      stability.push_back(summary);
  }
  field(out, "stability", stability);
}

void realtime_lines(std::ostream& out, const json& status) {
  const json rt = status.value("realtime", json::object());
  if (!rt.is_object() || rt.empty()) return;
  std::vector<std::string> items;
  items.push_back(rt.value("scheduler_set", false) ? "SCHED_FIFO priority " + text_of(rt, "priority", "?")
                                                   : "NOT real-time (SCHED_OTHER)");
  items.emplace_back(rt.value("memory_locked", false) ? "memory locked" : "memory NOT locked");
  items.emplace_back(rt.value("dma_latency_held", false) ? "cpu_dma_latency held"
                                                         : "cpu_dma_latency not held");
  field(out, "realtime", items);
  for (const auto& problem : rt.value("problems", json::array())) {
    out << continuation << "! " << scalar(problem) << '\n';
  }
}

void loop_lines(std::ostream& out, const json& stats) {
  if (!stats.is_object() || stats.empty()) return;
  std::vector<std::string> items{"latency " + histogram_text(stats.value("latency", json::object()), false)};
  items.push_back("overruns " + text_of(stats, "overruns", "?"));
  items.push_back("missed periods " + text_of(stats, "missed_periods", "?"));
  items.push_back("compute " + histogram_text(stats.value("compute", json::object()), false));
  field(out, "loop", items);
}

void recording_lines(std::ostream& out, const json& status) {
  const json rec = status.value("recording", json::object());
  if (!rec.is_object() || rec.empty()) return;
  const std::string path = text_of(rec, "path");
  std::vector<std::string> items;
  if (rec.value("active", false)) {
    items.push_back("recording to " + path);
  } else {
    items.emplace_back(path.empty() ? "off" : "off (last: " + path + ")");
  }
  if (!path.empty()) {
    items.push_back(text_of(rec, "samples", "0") + " samples");
    items.push_back(text_of(rec, "dropped", "0") + " dropped");
  }
  if (rec.value("disk_full", false))
    items.emplace_back("DISK FULL: rows are being dropped, retried every flush");
  if (const std::string error = text_of(rec, "error"); !error.empty()) items.push_back("error: " + error);
  field(out, "recording", items);
}

void last_lines(std::ostream& out, const json& status, const DeviceUnits& units) {
  const json last = status.value("last", json::object());
  if (!last.is_object() || last.empty()) return;
  field(out, "last",
        {"position " + text_of(last, "position", "?") + " " + units.position,
         "command " + text_of(last, "command", "?") + " " + units.force,
         "applied " + text_of(last, "applied", "?") + " " + units.force,
         "at " + format_value("time_s", last.value("time_s", json(nullptr)))});
}

}  // namespace

std::string microseconds_text(const json& us) {
  if (!us.is_number()) return "-";
  const double v = us.get<double>();
  std::ostringstream s;
  s.precision(3);
  if (v >= 1e6) {
    s << v * 1e-6 << " s";
  } else if (v >= 1e3) {
    s << v * 1e-3 << " ms";
  } else {
    s << v << " us";
  }
  return s.str();
}

std::string histogram_text(const json& h, bool with_tail) {
  if (!h.is_object() || h.value("count", 0) == 0) return "no samples yet";
  std::string text = "p50 " + microseconds_text(h.value("p50_us", json(nullptr))) + ", p99 " +
                     microseconds_text(h.value("p99_us", json(nullptr)));
  if (with_tail) text += ", p99.9 " + microseconds_text(h.value("p999_us", json(nullptr)));
  text += ", max " + microseconds_text(h.value("max_us", json(nullptr)));
  return text;
}

std::string status_text(const json& status, const json& stats) {
  std::ostringstream out;
  const DeviceUnits units = units_of(status);
  out << headline(status) << '\n';
  fault_lines(out, status);
  device_lines(out, status, units);
  calibration_lines(out, status);
  scene_lines(out, status);
  loop_lines(out, stats);
  realtime_lines(out, status);
  recording_lines(out, status);
  last_lines(out, status, units);
  return out.str();
}

}  // namespace detail

void add_status_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd =
      app.add_subcommand("status", "show the daemon's state, device, scene, loop timing and recording");
  add_common_options(*cmd, opts);
  static bool verbose = false;
  cmd->add_flag("--verbose,-v", verbose, "every member of the daemon's status, one per line");
  cmd->callback([&opts] {
    auto client = detail::connect(opts);
    json status;
    try {
      status = client.call("status", json::object());
    } catch (...) {
      detail::exit_for_current_exception("status");
    }
    if (opts.json) return detail::print_json(status);
    if (verbose) return detail::print_fields(std::cout, status);
    // Loop latency and overruns come from stats; a daemon that refuses it
    // still gets its status shown.
    json stats;
    try {
      stats = client.call("stats", json::object());
    } catch (const std::exception&) {
      stats = json();
    }
    std::cout << detail::status_text(status, stats);
  });
}

}  // namespace hapticctl
