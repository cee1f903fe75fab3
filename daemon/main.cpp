// hapticd: the real-time haptics daemon. See README.md and docs/.

#include <signal.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "daemon/config/config.hpp"
#include "daemon/planner.hpp"
#include "daemon/service.hpp"
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

/// --json: scene.list's result, its units for a device of `motion`, and
/// "current" null (no daemon runs a scene here).
void list_scenes(bool as_json, const std::string& motion) {
  if (as_json) {
    const auto m = motion == "rotary" ? hapticd::world::Motion::rotary : hapticd::world::Motion::linear;
    const nlohmann::json list{{"scenes", hapticd::daemon::scene_catalog_json(m)}, {"current", nullptr}};
    std::cout << list.dump(2) << "\n";
    return;
  }
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
  bool as_json = false;
  app.add_flag("--json", as_json, "--list-drivers (same as --format json) or --list-scenes as JSON");
  app.add_flag("--list-scenes", show_scenes, "list scenes and their parameters");
  std::string scenes_motion = "linear";
  app.add_option("--motion", scenes_motion, "--list-scenes --json: the units for a linear or rotary device")
      ->check(CLI::IsMember({"linear", "rotary"}));
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
    list_drivers(as_json ? "json" : drivers_format);
    return 0;
  }
  if (show_scenes) {
    list_scenes(as_json, scenes_motion);
    return 0;
  }

  // Block the stop signals before any thread starts: every thread inherits
  // the mask and the main thread takes them with sigtimedwait.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
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
    hapticd::daemon::Service service(std::move(options));
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
