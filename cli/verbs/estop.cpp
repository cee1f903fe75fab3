// hapticctl estop: zero the output and latch a fault at once.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_estop_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("estop", "emergency stop: zero the output now and latch a fault");
  add_common_options(*cmd, opts);
  cmd->callback([&opts] {
    auto result = detail::call(opts, "estop");
    if (opts.json) return detail::print_json(result);
    std::cout << "emergency stop: output zeroed; `hapticctl fault clear` to resume\n";
    if (result.is_object() && !result.empty()) detail::print_fields(std::cout, result, 2);
  });
}

}  // namespace hapticctl
