// hapticctl stats: loop timing, deadline misses, control-plane counters.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_stats_command(CLI::App& app, CommonOptions& opts) {
  auto* cmd = app.add_subcommand("stats", "show loop timing statistics and control-plane counters");
  add_common_options(*cmd, opts);
  cmd->callback([&opts] {
    auto result = detail::call(opts, "stats");
    if (opts.json) return detail::print_json(result);
    detail::print_fields(std::cout, result);
  });
}

}  // namespace hapticctl
