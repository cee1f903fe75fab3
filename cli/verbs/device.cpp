// hapticctl device [describe] | device call METHOD [key=value ...]
//
// What the device is (its driver, the parameters in force from the driver's
// own description, its state and model) and the methods its driver adds.

#include <iostream>

#include "cli/verbs.hpp"

namespace hapticctl {

namespace {

void print_description(const nlohmann::json& result) {
  const auto& driver = result["driver"];
  std::cout << "driver: " << detail::scalar(driver.value("name", "")) << " ("
            << detail::scalar(driver["status"]) << "): " << detail::scalar(driver["summary"]) << "\n"
            << "state: " << detail::scalar(result["state"]);
  if (!result["fault_reason"].get<std::string>().empty())
    std::cout << " (" << detail::scalar(result["fault_reason"]) << ")";
  std::cout << "\nmodel: " << detail::scalar(result["model"]["summary"]) << " (from "
            << detail::scalar(result["model"]["source"]) << ")\nsettings:\n";
  const auto& values = result["values"];
  // Units written "rotary | linear" (kg m^2 | kg): the one of this device.
  const bool linear = values.value("motion", "") == "linear";
  for (const auto& p : driver["parameters"]) {
    const std::string name = p["name"];
    std::string unit = p["unit"];
    if (const auto bar = unit.find(" | "); bar != std::string::npos) {
      unit = linear ? unit.substr(bar + 3) : unit.substr(0, bar);
    }
    std::cout << "  " << name << " = " << (values.contains(name) ? detail::scalar(values[name]) : "-");
    if (!unit.empty()) std::cout << " " << unit;
    std::cout << "\n";
  }
  if (!result["counters"].empty()) {
    std::cout << "counters:\n";
    detail::print_fields(std::cout, result["counters"], 2);
  }
}

}  // namespace

void add_device_command(CLI::App& app, CommonOptions& opts) {
  struct Args {
    std::string method;
    std::vector<std::string> assignments;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("device", "what the device is, and the methods its driver adds");
  add_common_options(*cmd, opts);
  auto* describe = cmd->add_subcommand("describe", "driver, settings in force, state, model (the default)");
  add_common_options(*describe, opts);
  auto show = [&opts] {
    auto result = detail::call(opts, "device.describe");
    if (opts.json) return detail::print_json(result);
    print_description(result);
  };
  describe->callback(show);
  auto* call = cmd->add_subcommand("call", "call a method the driver adds: METHOD [key=value ...]");
  add_common_options(*call, opts);
  call->add_option("method", args->method, "e.g. hand.set (loopback)")->required();
  call->add_option("params", args->assignments, "name=value pairs");
  call->callback([&opts, args] {
    auto result = detail::call(opts, args->method, detail::assignments(args->assignments));
    if (opts.json) return detail::print_json(result);
    detail::print_fields(std::cout, result);
  });
  cmd->callback([cmd, show] {
    if (cmd->get_subcommands().empty()) show();
  });
}

}  // namespace hapticctl
