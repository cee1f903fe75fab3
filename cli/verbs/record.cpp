// hapticctl record start [--path NAME] | record stop

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_record_command(CLI::App& app, CommonOptions& opts) {
  struct Args {
    std::string path;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("record", "record telemetry to a file in the daemon");
  cmd->require_subcommand(1);
  add_common_options(*cmd, opts);

  auto* start = cmd->add_subcommand("start", "start a recording");
  add_common_options(*start, opts);
  start->add_option("--path", args->path,
                    "file name in the daemon's recording directory (default: a time-stamped name); "
                    "every channel of the scene is recorded");
  start->callback([&opts, args] {
    nlohmann::json params = nlohmann::json::object();
    if (!args->path.empty()) params["path"] = args->path;
    auto result = detail::call(opts, "record.start", params);
    if (opts.json) return detail::print_json(result);
    std::cout << "recording to " << result.value("path", std::string("?")) << '\n';
  });

  auto* stop = cmd->add_subcommand("stop", "stop the recording and flush it");
  add_common_options(*stop, opts);
  stop->callback([&opts] {
    auto result = detail::call(opts, "record.stop");
    if (opts.json) return detail::print_json(result);
    detail::print_fields(std::cout, result);
  });
}

}  // namespace hapticctl
