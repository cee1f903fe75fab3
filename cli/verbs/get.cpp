// hapticctl get [NAME ...]: the current scene's parameters.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_get_command(CLI::App& app, CommonOptions& opts) {
  auto names = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand("get", "show parameters of the current scene (all, or those named)");
  add_common_options(*cmd, opts);
  cmd->add_option("names", *names, "parameter names");
  cmd->callback([&opts, names] {
    nlohmann::json params = nlohmann::json::object();
    if (!names->empty()) params["names"] = *names;
    auto result = detail::call(opts, "param.get", params);
    if (opts.json) return detail::print_json(result);
    if (result.contains("scene")) std::cout << "scene: " << result["scene"].get<std::string>() << '\n';
    detail::print_params(std::cout, result.value("parameters", nlohmann::json::object()),
                         result.value("units", nlohmann::json::object()));
  });
}

}  // namespace hapticctl
