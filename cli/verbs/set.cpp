// hapticctl set name=value ... [--force]

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_set_command(CLI::App& app, CommonOptions& opts) {
  struct Args {
    std::vector<std::string> assignments;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("set", "change parameters of the current scene (name=value ...)");
  add_common_options(*cmd, opts);
  cmd->add_option("params", args->assignments, "parameters as name=value")->required();
  cmd->add_flag("--force", args->force, "apply even if the parameters are unstable");
  cmd->callback([&opts, args] {
    nlohmann::json params{{"params", detail::assignments(args->assignments)}};
    if (args->force) params["force"] = true;
    auto result = detail::call(opts, "param.set", params);
    if (opts.json) return detail::print_json(result);
    detail::print_scene_result(result);
  });
}

}  // namespace hapticctl
