// hapticd: the real-time haptics daemon. See README.md and docs/.

#include <signal.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "daemon/config/config.hpp"
#include "daemon/config/host_checks_setup.hpp"
#include "daemon/planner.hpp"
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

/// Every scene from the registry, as text, the markdown of docs/scenes.md,
/// or JSON (scene.list's result, units for a device of `motion`, "current"
/// null: no daemon runs a scene here).
void list_scenes(const std::string& format, const std::string& motion) {
  namespace world = hapticd::world;
  if (format == "json") {
    const auto m = motion == "rotary" ? world::Motion::rotary : world::Motion::linear;
    const nlohmann::json list{{"scenes", hapticd::daemon::scene_catalog_json(m)}, {"current", nullptr}};
    std::cout << list.dump(2) << "\n";
    return;
  }
  if (format == "markdown") {
    std::cout << hapticd::daemon::scene_catalog_markdown();
    return;
  }
  for (const auto& s : world::scene_catalog()) {
    std::cout << s.name << ": " << s.summary << " [" << s.reference << "]\n";
    for (const auto& p : s.parameters) {
      std::cout << "  " << p.name << " (" << world::scene_type_name(p.type)
                << (p.unit.empty() ? "" : ", " + p.unit) << "): " << p.help << "\n";
    }
  }
}

/// --version, --list-drivers, --list-scenes and their output options: what
/// hapticd prints and exits on, without a config or a device.
struct Listings {
  bool version = false;
  bool drivers = false;
  bool scenes = false;
  bool json = false;
  std::string format = "text";
  std::string motion = "linear";

  void add_to(CLI::App& app) {
    app.add_flag("--list-drivers", drivers, "list drivers and their parameters (ready or planned)");
    app.add_option("--format", format, "--list-drivers or --list-scenes output: text, json or markdown")
        ->check(CLI::IsMember({"text", "json", "markdown"}));
    app.add_flag("--json", json, "--list-drivers or --list-scenes as JSON (same as --format json)");
    app.add_flag("--list-scenes", scenes, "list scenes and their parameters");
    app.add_option("--motion", motion, "--list-scenes --json: the units for a linear or rotary device")
        ->check(CLI::IsMember({"linear", "rotary"}));
    app.add_flag("--version", version, "print the version");
  }

  /// Prints what was asked for; false if nothing was.
  bool print() const {
    if (version) {
      std::cout << "hapticd " << hapticd::version << "\n";
    } else if (drivers) {
      list_drivers(json ? "json" : format);
    } else if (scenes) {
      list_scenes(json ? "json" : format, motion);
    }
    return version || drivers || scenes;
  }
};

/// hapticd --setup-check [--json]: exit 0 when every item is ok or a
/// warning, 1 on a failure (a config that does not load is one).
int setup_check(const std::string& config_path, bool json) {
  namespace config = hapticd::daemon::config;
  const config::SetupFacts facts = config::probe_setup_facts();
  config::DaemonConfig cfg;
  std::vector<config::SetupItem> items;
  try {
    cfg = config_path.empty() ? config::default_config() : config::load_config(config_path);
    config::SetupContext context;
    context.ip_details = config::run_ip_details;
    context.state_directory_env = std::getenv("STATE_DIRECTORY");  // NOLINT(concurrency-mt-unsafe)
    items = config::run_setup_check(cfg, facts, context);
  } catch (const config::ConfigError& e) {
    cfg.source = config_path;
    items = {{"config", config::Verdict::fail, e.what(), "the key it names (docs/config.md)"}};
  }
  if (json) {
    std::cout << config::to_json(cfg, facts, items).dump(2) << "\n";
  } else {
    std::cout << config::to_text(cfg, facts, items);
  }
  return config::overall(items) == config::Verdict::fail ? 1 : 0;
}

/// The command line: where the config is, what to override in it, and what
/// to do instead of running (check the config or the machine, list).
struct DaemonFlags {
  std::string config_path;
  bool require_rt = false;
  bool check_config = false;
  bool setup = false;
  Listings listings;
  std::string clock;
  std::string duration;
  std::string record;
  std::string socket;

  void add_to(CLI::App& app) {
    app.add_option("-c,--config", config_path, "TOML config file (default: the built-in loopback wheel)");
    app.add_flag("--require-rt", require_rt, "exit if SCHED_FIFO cannot be had");
    app.add_option("--clock", clock, "real or virtual (virtual: as fast as possible on simulated time)");
    app.add_option("--duration", duration, "stop after this much loop time (s, ms, us)");
    app.add_option("--record", record,
                   "record from the first cycle to this file name in the recording directory");
    app.add_option("--socket", socket, "control socket path");
    app.add_flag("--check-config", check_config, "validate the config, print what would run, exit");
    listings.add_to(app);
    app.add_flag(
        "--setup-check", setup,
        "check this machine for this config (RT limits, kernel, CPUs, device access, budget), exit 1 on a "
        "failure; --json for JSON");
  }
};

/// --require-rt, --clock and --duration over the config's [loop]; false
/// (after saying why on stderr) when --clock or --duration is refused.
bool apply_loop_flags(const DaemonFlags& flags, hapticd::daemon::config::LoopConfig& loop) {
  if (flags.require_rt) loop.require_rt = true;
  if (!flags.clock.empty()) {
    if (flags.clock == "real") {
      loop.clock = hapticd::daemon::config::ClockKind::real;
    } else if (flags.clock == "virtual") {
      loop.clock = hapticd::daemon::config::ClockKind::virtual_clock;
    } else {
      std::cerr << "hapticd: --clock: '" << flags.clock << "' is not accepted; accepted: real, virtual\n";
      return false;
    }
  }
  if (!flags.duration.empty()) {
    const auto d = hapticd::world::units::parse_duration_s(flags.duration);
    if (!d || *d <= 0) {
      std::cerr << "hapticd: --duration: '" << flags.duration
                << "' is not accepted; expected a duration > 0 such as 10s or 500ms\n";
      return false;
    }
    loop.duration_s = *d;
  }
  return true;
}

/// Configures the device (a stop signal meanwhile ends it, exit 0), then
/// prints the plan (--check-config) or runs the loop until it stops.
int configure_and_run(hapticd::daemon::ServiceOptions options, const hapticd::drivers::StopRequest& stop,
                      bool check_config) {
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
}

/// The daemon: the config with the flags over it, the device, the loop. Exit
/// 0 when it stopped as asked, 1 on a device or other failure, 2 on a
/// refused config or flag.
int run_daemon(const DaemonFlags& flags) {
  // The stop signals are taken from here on, before any other thread starts
  // (each inherits the mask): a SIGTERM while the device is configured or
  // enabled ends that step within drivers::stop_slice, not after its timeout.
  hapticd::drivers::StopRequest stop;
  hapticd::daemon::system::StopSignals stop_signals(
      [&stop](int signal) { stop.request(hapticd::daemon::system::StopSignals::name(signal)); });
  signal(SIGPIPE, SIG_IGN);

  try {
    hapticd::daemon::ServiceOptions options;
    options.config = flags.config_path.empty() ? hapticd::daemon::config::default_config()
                                               : hapticd::daemon::config::load_config(flags.config_path);
    auto& loop = options.config.loop;
    if (!apply_loop_flags(flags, loop)) return 2;
    if (!flags.socket.empty()) {
      options.config.control.socket = flags.socket;
      options.config.control.socket_where = {"--socket", 0, 0};  // errors name the flag, not the file
    }
    options.record_name = flags.record;
    options.stop = &stop;
    if (loop.cpu >= 0) {
      if (const auto problem = stop_signals.keep_off_cpu(loop.cpu); !problem.empty())
        std::cerr << "hapticd: " << problem << "\n";
    }
    return configure_and_run(std::move(options), stop, flags.check_config);
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hapticd: real-time haptics daemon"};
  DaemonFlags flags;
  flags.add_to(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "hapticd: " << e.what() << " (see hapticd --help)\n";
    return 2;
  }
  if (flags.listings.print()) return 0;
  if (flags.setup) return setup_check(flags.config_path, flags.listings.json);
  return run_daemon(flags);
}
