// hapticctl status: the daemon's state, device, scene and fault.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_status_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("status", "show the daemon's state, device, scene and latched fault");
  add_common_options(*cmd, opts);
  cmd->callback([&opts] {
    auto result = detail::call(opts, "status");
    if (opts.json) return detail::print_json(result);
    detail::print_fields(std::cout, result);
  });
}

}  // namespace hapticctl
