// hapticctl hand [MODE] [key=value ...]: the loopback device's scripted hand.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_hand_command(CLI::App& app, CommonOptions& opts) {
  auto words = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand("hand",
                                 "script the loopback hand: [MODE] key=value ... (e.g. `hand hold "
                                 "trajectory=sine amplitude=0.1 frequency=1`)");
  add_common_options(*cmd, opts);
  cmd->add_option("args", *words,
                  "a mode (free, hold, force, impedance) and key=value (trajectory=step|ramp|sine, "
                  "amplitude, at, release_at, ...)")
      ->required();
  cmd->callback([&opts, words] {
    std::vector<std::string> rest = *words;
    nlohmann::json params = nlohmann::json::object();
    if (!rest.empty() && rest.front().find('=') == std::string::npos) {
      params["mode"] = rest.front();
      rest.erase(rest.begin());
    }
    const nlohmann::json given = detail::assignments(rest);
    for (const auto& [key, value] : given.items()) {
      if (key == "mode" && params.contains("mode")) {
        std::cerr << "hapticctl: mode given twice\n";
        throw Exit(exit_code::usage);
      }
      params[key] = value;
    }
    auto result = detail::call(opts, "hand.set", params);
    if (opts.json) return detail::print_json(result);
    // What the daemon applied, not what was typed.
    std::cout << "hand: " << result.value("hand", std::string("?")) << " (from cycle "
              << result.value("cycle", 0) << ")\n";
  });
}

}  // namespace hapticctl
