// hapticctl fault inject KIND [key=value ...] | fault clear

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

void add_fault_command(CLI::App& app, CommonOptions& opts) {
  struct Args {
    std::string kind;
    std::vector<std::string> assignments;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("fault", "inject faults (loopback device) or clear a latched fault");
  cmd->require_subcommand(1);
  add_common_options(*cmd, opts);

  auto* inject = cmd->add_subcommand("inject", "inject a fault: KIND [key=value ...]");
  add_common_options(*inject, opts);
  inject->add_option("kind", args->kind, "read-error, stall, nan, encoder-jump, fault")->required();
  inject->add_option("params", args->assignments,
                     "amount=N: periods (default: until cleared), or counts for encoder-jump (required)");
  inject->callback([&opts, args] {
    nlohmann::json params = detail::assignments(args->assignments);
    if (params.contains("kind")) {
      std::cerr << "hapticctl: kind given twice\n";
      throw Exit(exit_code::usage);
    }
    params["kind"] = args->kind;
    auto result = detail::call(opts, "fault.inject", params);
    if (opts.json) return detail::print_json(result);
    std::cout << "injected " << args->kind << '\n';
    if (result.is_object() && !result.empty()) detail::print_fields(std::cout, result, 2);
  });

  auto* clear = cmd->add_subcommand("clear", "clear a latched fault and resume");
  add_common_options(*clear, opts);
  clear->callback([&opts] {
    auto result = detail::call(opts, "fault.clear");
    if (opts.json) return detail::print_json(result);
    std::cout << "fault cleared\n";
    if (result.is_object() && !result.empty()) detail::print_fields(std::cout, result, 2);
  });
}

}  // namespace hapticctl
