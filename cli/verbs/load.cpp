// hapticctl load SCENE [name=value ...] [--force]

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_load_command(CLI::App& app, CommonOptions& opts) {
  struct Args {
    std::string scene;
    std::vector<std::string> assignments;
    bool force = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("load", "load a scene, optionally with parameters (name=value)");
  add_common_options(*cmd, opts);
  cmd->add_option("scene", args->scene, "scene name (see `hapticctl scenes`)")->required();
  cmd->add_option("params", args->assignments, "parameters as name=value");
  cmd->add_flag("--force", args->force, "load even if the parameters are unstable");
  cmd->callback([&opts, args] {
    nlohmann::json params{{"scene", args->scene}, {"params", detail::assignments(args->assignments)}};
    if (args->force) params["force"] = true;
    auto result = detail::call(opts, "scene.load", params);
    if (opts.json) return detail::print_json(result);
    detail::print_scene_result(result);
  });
}

}  // namespace hapticctl
