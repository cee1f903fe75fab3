// hapticctl scenes: the scenes the daemon can load, '*' on the current one,
// each with its parameters (default, unit, what it is).

#include <algorithm>
#include <iostream>
#include <string>

#include "cli/verbs.hpp"

namespace hapticctl {

namespace {

using nlohmann::json;

void print_scene(const json& scene, bool current) {
  std::cout << (current ? "* " : "  ") << scene.value("name", std::string("?")) << "  "
            << scene.value("summary", std::string()) << '\n';
  const std::string reference = scene.value("reference", std::string());
  if (!reference.empty()) std::cout << "    from " << reference << '\n';
  const json params = scene.value("parameters", json::array());
  std::size_t name_width = 0, default_width = 0, unit_width = 0;
  for (const auto& p : params) {
    name_width = std::max(name_width, p.value("name", std::string()).size());
    default_width = std::max(default_width, detail::scalar(p.value("default", json())).size());
    unit_width = std::max(unit_width, p.value("unit", std::string()).size());
  }
  for (const auto& p : params) {
    const std::string name = p.value("name", std::string());
    const std::string def = detail::scalar(p.value("default", json()));
    const std::string unit = p.value("unit", std::string());
    std::string help = p.value("help", std::string());
    if (p.contains("accepted") && p["accepted"].is_array()) {
      std::string accepted;
      for (const auto& a : p["accepted"]) accepted += (accepted.empty() ? "" : ", ") + detail::scalar(a);
      help += " [" + accepted + "]";
    }
    std::cout << "    " << name << std::string(name_width - name.size() + 2, ' ') << def
              << std::string(default_width - def.size() + 2, ' ') << unit
              << std::string(unit_width - unit.size() + 2, ' ') << help << '\n';
  }
}

}  // namespace

void add_scenes_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("scenes", "list the scenes, their parameters, defaults and units");
  add_common_options(*cmd, opts);
  cmd->callback([&opts] {
    auto result = detail::call(opts, "scene.list");
    if (opts.json) return detail::print_json(result);
    const std::string current = result.value("current", std::string());
    bool first = true;
    for (const auto& scene : result.value("scenes", json::array())) {
      if (!first) std::cout << '\n';
      first = false;
      print_scene(scene, scene.value("name", std::string()) == current);
    }
  });
}

}  // namespace hapticctl
