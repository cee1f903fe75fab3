#pragma once
/// \file
/// The daemon verbs of hapticctl: each talks to a running hapticd over its
/// control socket (docs/protocol.md). One file per verb in cli/verbs/.
///
/// cli/main.cpp:
///     CLI::App app{"hapticctl: control and analyze hapticd"};
///     hapticctl::CommonOptions opts;
///     hapticctl::add_daemon_commands(app, opts);
///     ... add the offline verbs (analyze) ...
///     return hapticctl::run(app, argc, argv);

#include <exception>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "client/client.hpp"

namespace hapticctl {

/// Exit codes of hapticctl.
namespace exit_code {
inline constexpr int ok = 0;
inline constexpr int refused = 1;      ///< the daemon refused or failed the request (reason on stderr)
inline constexpr int usage = 2;        ///< bad command line (CLI11 errors, malformed name=value)
inline constexpr int unreachable = 3;  ///< no daemon at the socket, or it stopped answering
}  // namespace exit_code

/// Options every daemon verb takes (on the app and on each verb).
struct CommonOptions {
  std::string socket;      ///< --socket PATH; empty: client::resolve_client_socket_path()
  std::string instance;    ///< --instance NAME: hapticd@NAME.service's socket
  bool json = false;       ///< --json: print the daemon's result object as JSON
  double timeout_s = 5.0;  ///< --timeout SECONDS for connecting and for each call
};

/// Ends hapticctl with `code`; the verb has already printed why.
class Exit : public std::exception {
 public:
  explicit Exit(int exit_code) noexcept : code_(exit_code) {}
  int code() const noexcept { return code_; }
  const char* what() const noexcept override { return "hapticctl exit"; }

 private:
  int code_;
};

/// Adds --socket, --instance, --json and --timeout to `app` (skipping any it already has).
void add_common_options(CLI::App& app, CommonOptions& opts);

void add_status_command(CLI::App& app, CommonOptions& opts);  ///< status
void add_scenes_command(CLI::App& app, CommonOptions& opts);  ///< scenes
void add_load_command(CLI::App& app, CommonOptions& opts);    ///< load SCENE [name=value ...] [--force]
void add_get_command(CLI::App& app, CommonOptions& opts);     ///< get [NAME ...]
void add_set_command(CLI::App& app, CommonOptions& opts);     ///< set name=value ... [--force]
void add_record_command(CLI::App& app,
                        CommonOptions& opts);  ///< record start [--path P] [--channel C] | record stop
void add_stream_command(CLI::App& app,
                        CommonOptions& opts);               ///< stream [--rate HZ] [--count N] [CHANNEL ...]
void add_hand_command(CLI::App& app, CommonOptions& opts);  ///< hand [MODE] [key=value ...]
void add_fault_command(CLI::App& app,
                       CommonOptions& opts);  ///< fault inject KIND [key=value ...] | fault clear
void add_estop_command(CLI::App& app, CommonOptions& opts);   ///< estop
void add_stats_command(CLI::App& app, CommonOptions& opts);   ///< stats
void add_device_command(CLI::App& app, CommonOptions& opts);  ///< device [describe] | device call METHOD ...
void add_telemetry_command(
    CLI::App& app,
    CommonOptions& opts);  ///< telemetry [on|off] [udp=A:P rate_hz= channels= batch= prefix=]

/// All of the above, plus the common options on `app`, in one call.
void add_daemon_commands(CLI::App& app, CommonOptions& opts);

/// Parses and runs: returns 0, or the exit code of a CLI11 error (2; 0 for
/// --help) or of an Exit thrown by a verb.
int run(CLI::App& app, int argc, const char* const* argv);

/// Helpers shared by the verb files.
namespace detail {

/// Connects, or prints why not and throws Exit(unreachable).
hapticd::client::Client connect(const CommonOptions& opts);
/// connect() + call(); a daemon error prints "hapticctl: METHOD: refused:
/// message" (and its data) to stderr and throws Exit(refused); a lost
/// connection throws Exit(unreachable).
nlohmann::json call(const CommonOptions& opts, const std::string& method,
                    const nlohmann::json& params = nlohmann::json::object());
/// Inside a catch block: report the current client exception and throw Exit.
[[noreturn]] void exit_for_current_exception(const std::string& method);
/// name=value words as a JSON object; malformed ones print and throw Exit(usage).
nlohmann::json assignments(const std::vector<std::string>& words);

/// A scalar for people: strings bare, null "-", floats to 6 significant digits.
std::string scalar(const nlohmann::json& value);
/// "period_us" -> "period", "rate_hz" -> "rate": the key without its unit suffix.
std::string display_key(const std::string& key);
/// A value with the unit of the key's suffix: ("period_us", 1000) -> "1000 us".
std::string format_value(const std::string& key, const nlohmann::json& value);
/// Aligned "key: value unit" lines; nested objects indented below their key.
void print_fields(std::ostream& out, const nlohmann::json& object, int indent = 0);
/// A parameter table NAME VALUE UNIT from {"name": value} and {"name": unit}.
void print_params(std::ostream& out, const nlohmann::json& parameters, const nlohmann::json& units);
/// A scene.load / param.set result: scene, effective cycle, parameters with
/// units, notes, stability; a set loaded with --force also warns on stderr
/// (growth per second, the torque limit still holds).
void print_scene_result(const nlohmann::json& result);
/// The daemon's result as JSON (for --json).
void print_json(const nlohmann::json& result);

}  // namespace detail
}  // namespace hapticctl
