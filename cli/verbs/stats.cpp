// hapticctl stats: loop timing, deadline misses, control-plane counters, for
// a person (one screen), --verbose for every member, --json unchanged.

#include <iostream>
#include <sstream>
#include <string>

#include "cli/verbs.hpp"
#include "cli/verbs/status_text.hpp"

namespace hapticctl {

using nlohmann::json;

namespace detail {
namespace {

std::string count_of(const json& object, const char* key) {
  return object.is_object() && object.contains(key) ? scalar(object[key]) : "?";
}

void line(std::ostream& out, const std::string& name, const std::string& value) {
  std::string head = "  " + name + ":";
  head += std::string(head.size() < 13 ? 13 - head.size() : 1, ' ');
  out << head << value << '\n';
}

std::string device_counters(const json& device) {
  if (!device.is_object()) return "-";
  std::string text = "read errors " + count_of(device, "read_errors") + ", write errors " +
                     count_of(device, "write_errors") + ", faults " + count_of(device, "faults");
  for (const auto& [name, value] : device.items()) {
    if (name == "read_errors" || name == "write_errors" || name == "faults") continue;
    text += ", " + name + " " + scalar(value);
  }
  return text;
}

}  // namespace

std::string stats_text(const json& s) {
  std::ostringstream out;
  out << "loop statistics since cycle " << count_of(s, "since_cycle") << ": " << count_of(s, "cycles")
      << " cycles\n";
  line(out, "latency",
       histogram_text(s.value("latency", json::object()), true) + " (wake-up after the deadline)");
  line(out, "compute", histogram_text(s.value("compute", json::object()), true) + " (read + step + write)");
  line(out, "overruns",
       count_of(s, "overruns") + " (woken a period or more late), missed periods " +
           count_of(s, "missed_periods") + ", longest streak " + count_of(s, "max_overrun_streak") +
           ", now " + count_of(s, "overrun_streak"));
  out << "totals since start:\n";
  line(out, "loop",
       "read errors " + count_of(s, "read_errors") + ", write errors " + count_of(s, "write_errors") +
           ", faults latched " + count_of(s, "faults_latched") + ", torque-limited cycles " +
           count_of(s, "torque_limited"));
  line(out, "device", device_counters(s.value("device", json::object())));
  const json rec = s.value("recorder", json::object());
  std::string recorder = count_of(rec, "samples_drained") + " samples drained, " +
                         count_of(rec, "samples_written") + " written, dropped " +
                         count_of(rec, "dropped_ring_total") + " (ring) + " + count_of(rec, "dropped_write") +
                         " (write)";
  if (rec.is_object() && rec.contains("error") && !scalar(rec["error"]).empty()) {
    recorder += ", error: " + scalar(rec["error"]);
  }
  line(out, "recorder", recorder);
  const json control = s.value("control", json::object());
  line(out, "control",
       count_of(control, "clients") + " clients (" + count_of(control, "subscribers") + " streaming), " +
           count_of(control, "requests") + " requests, " + count_of(control, "errors") + " errors, " +
           count_of(control, "connections") + " connections (" + count_of(control, "refused_busy") +
           " refused busy)");
  line(out, "telemetry",
       count_of(control, "notifications_sent") + " notifications sent, " +
           count_of(control, "notifications_dropped") + " dropped for slow readers, " +
           count_of(s, "telemetry_dropped") + " samples dropped by the loop");
  return out.str();
}

}  // namespace detail

void add_stats_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("stats", "show loop timing statistics and control-plane counters");
  add_common_options(*cmd, opts);
  static bool verbose = false;
  cmd->add_flag("--verbose,-v", verbose, "every member of the daemon's stats, one per line");
  cmd->callback([&opts] {
    auto result = detail::call(opts, "stats");
    if (opts.json) return detail::print_json(result);
    if (verbose) return detail::print_fields(std::cout, result);
    std::cout << detail::stats_text(result);
  });
}

}  // namespace hapticctl
