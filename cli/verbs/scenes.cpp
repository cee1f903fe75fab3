// hapticctl scenes: the scenes the daemon can load, '*' on the current one.

#include <algorithm>
#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_scenes_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("scenes", "list the scenes and their parameters");
  add_common_options(*cmd, opts);
  cmd->callback([&opts] {
    auto result = detail::call(opts, "scene.list");
    if (opts.json) return detail::print_json(result);
    const auto scenes = result.value("scenes", nlohmann::json::array());
    const std::string current = result.contains("current") && result["current"].is_string()
                                    ? result["current"].get<std::string>()
                                    : std::string();
    std::size_t width = 0;
    for (const auto& s : scenes) width = std::max(width, s.value("name", std::string()).size());
    for (const auto& s : scenes) {
      std::string name = s.value("name", std::string("?"));
      std::cout << (name == current ? "* " : "  ") << name << std::string(width - name.size() + 2, ' ')
                << s.value("description", std::string()) << '\n';
      if (s.contains("params") && s["params"].is_array() && !s["params"].empty()) {
        std::string line;
        for (const auto& p : s["params"]) {
          std::string item = p.is_object() ? p.value("name", std::string("?")) : p.dump();
          if (p.is_object() && p.contains("unit") && p["unit"].is_string() &&
              !p["unit"].get<std::string>().empty()) {
            item += " [" + p["unit"].get<std::string>() + "]";
          }
          line += (line.empty() ? "" : ", ") + item;
        }
        std::cout << std::string(width + 4, ' ') << line << '\n';
      }
    }
  });
}

}  // namespace hapticctl
