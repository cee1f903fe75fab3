// hapticd: the real-time haptics daemon. See README.md and docs/.

#include <signal.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "daemon/config/config.hpp"
#include "daemon/service.hpp"
#include "daemon/system/stop_signals.hpp"
#include "daemon/version.hpp"
#include "drivers/registry.hpp"
#include "world/scene_catalog.hpp"
#include "world/units.hpp"

namespace {

/// Every driver from the registry, as text, JSON or the markdown reference page.
void list_drivers(const std::string& format) {
  namespace drivers = hapticd::drivers;
  if (format == "json") {
    nlohmann::json all = nlohmann::json::array();
    for (const auto& d : drivers::driver_registry()) all.push_back(drivers::to_json(d));
    std::cout << all.dump(2) << "\n";
    return;
  }
  if (format == "markdown") {
    std::cout << drivers::to_markdown(drivers::driver_registry());
    return;
  }
  for (const auto& d : drivers::driver_registry()) {
    std::cout << d.name << (d.ready ? "" : " (planned: not built in this version)") << ": " << d.summary
              << "\n";
    for (const auto& p : d.parameters) {
      std::string def = p.default_value ? drivers::to_text(*p.default_value)
                                        : (p.type == drivers::ParameterType::table ? "-" : "required");
      if (!p.default_note.empty()) def += " (" + p.default_note + ")";
      std::cout << "  " << p.name << ": " << drivers::accepted_text(p) << "; default " << def << ". "
                << p.help << "\n";
    }
  }
}

void list_scenes() {
  for (const auto& s : hapticd::world::scene_catalog()) {
    std::cout << s.name << ": " << s.summary << " [" << s.reference << "]\n";
    for (const auto& p : s.parameters) {
      std::cout << "  " << p.name << " (" << hapticd::world::to_string(p.type)
                << (p.unit.empty() ? "" : ", " + p.unit) << "): " << p.help << "\n";
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hapticd: real-time haptics daemon"};
  std::string config_path;
  bool require_rt = false;
  bool check_config = false;
  bool show_drivers = false;
  std::string drivers_format = "text";
  bool show_scenes = false;
  bool show_version = false;
  std::string clock;
  std::string duration;
  std::string record;
  std::string socket;
  app.add_option("-c,--config", config_path, "TOML config file (default: the built-in loopback wheel)");
  app.add_flag("--require-rt", require_rt, "exit if SCHED_FIFO cannot be had");
  app.add_option("--clock", clock, "real or virtual (virtual: as fast as possible on simulated time)");
  app.add_option("--duration", duration, "stop after this much loop time (s, ms, us)");
  app.add_option("--record", record,
                 "record from the first cycle to this file name in the recording directory");
  app.add_option("--socket", socket, "control socket path");
  app.add_flag("--check-config", check_config, "validate the config, print what would run, exit");
  app.add_flag("--list-drivers", show_drivers, "list drivers and their parameters (ready or planned)");
  app.add_option("--format", drivers_format, "--list-drivers output: text, json or markdown")
      ->check(CLI::IsMember({"text", "json", "markdown"}));
  bool drivers_json = false;
  app.add_flag("--json", drivers_json, "--list-drivers as JSON (same as --format json)");
  app.add_flag("--list-scenes", show_scenes, "list scenes and their parameters");
  app.add_flag("--version", show_version, "print the version");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "hapticd: " << e.what() << " (see hapticd --help)\n";
    return 2;
  }
  if (show_version) {
    std::cout << "hapticd " << hapticd::version << "\n";
    return 0;
  }
  if (show_drivers) {
    list_drivers(drivers_json ? "json" : drivers_format);
    return 0;
  }
  if (show_scenes) {
    list_scenes();
    return 0;
  }

  // The stop signals are taken from here on, before any other thread starts
  // (each inherits the mask): a SIGTERM while the device is configured or
  // enabled ends that step within drivers::stop_slice, not after its timeout.
  hapticd::drivers::StopRequest stop;
  hapticd::daemon::system::StopSignals stop_signals(
      [&stop](int signal) { stop.request(hapticd::daemon::system::StopSignals::name(signal)); });
  signal(SIGPIPE, SIG_IGN);

  try {
    hapticd::daemon::ServiceOptions options;
    options.config = config_path.empty() ? hapticd::daemon::config::default_config()
                                         : hapticd::daemon::config::load_config(config_path);
    auto& loop = options.config.loop;
    if (require_rt) loop.require_rt = true;
    if (!clock.empty()) {
      if (clock == "real") {
        loop.clock = hapticd::daemon::config::ClockKind::real;
      } else if (clock == "virtual") {
        loop.clock = hapticd::daemon::config::ClockKind::virtual_clock;
      } else {
        std::cerr << "hapticd: --clock: '" << clock << "' is not accepted; accepted: real, virtual\n";
        return 2;
      }
    }
    if (!duration.empty()) {
      const auto d = hapticd::world::units::parse_duration_s(duration);
      if (!d || *d <= 0) {
        std::cerr << "hapticd: --duration: '" << duration
                  << "' is not accepted; expected a duration > 0 such as 10s or 500ms\n";
        return 2;
      }
      loop.duration_s = *d;
    }
    if (!socket.empty()) {
      options.config.control.socket = socket;
      options.config.control.socket_where = {"--socket", 0, 0};  // errors name the flag, not the file
    }
    options.record_name = record;
    options.stop = &stop;
    if (loop.cpu >= 0) {
      if (const auto problem = stop_signals.keep_off_cpu(loop.cpu); !problem.empty())
        std::cerr << "hapticd: " << problem << "\n";
    }
    std::unique_ptr<hapticd::daemon::Service> configured;
    try {
      configured = std::make_unique<hapticd::daemon::Service>(std::move(options));
    } catch (const hapticd::drivers::StopRequested& e) {
      // The device is closed (disabled) again; a stop is not a failure.
      std::cout << "hapticd: stopped by " << stop.why() << " during configure (" << e.what() << ")"
                << std::endl;
      return 0;
    }
    hapticd::daemon::Service& service = *configured;
    if (check_config) {
      std::cout << service.describe() << "\nconfig OK\n";
      return 0;
    }
    return service.run();
  } catch (const hapticd::drivers::DeviceError& e) {
    std::cerr << "hapticd: device: " << e.what() << "\n";
    return 1;
  } catch (const hapticd::daemon::config::ConfigError& e) {
    std::cerr << "hapticd: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "hapticd: " << e.what() << "\n";
    return 1;
  }
}
