// hapticctl device [describe] | device call METHOD [key=value ...] | device zero
//          | device sdo read INDEX SUB [--type T] [--node N]
//          | device sdo write INDEX SUB VALUE [--type T] [--node N]
//
// What the device is (its driver, the parameters in force from the driver's
// own description, its state and model) and the methods its driver adds;
// `zero` sets the origin (device.zero, docs/protocol.md); `sdo` is the
// canopen driver's commissioning access (device.sdo.read/write).

#include <iomanip>
#include <iostream>
#include <memory>

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

/// "0x6041:00 statusword = 567 (raw 0x00000237, u16)"
void print_sdo(const nlohmann::json& r) {
  if (r.contains("node")) std::cout << "node " << r["node"].get<int>() << ": ";  // one of several drives
  std::cout << r["index"].get<std::string>() << ":" << std::setw(2) << std::setfill('0') << std::hex
            << r["sub"].get<int>() << std::dec << std::setfill(' ');
  if (!r["name"].get<std::string>().empty()) std::cout << " " << r["name"].get<std::string>();
  std::cout << " = " << r["value"].get<std::int64_t>() << " (raw " << r["raw"].get<std::string>();
  if (!r["type"].is_null()) std::cout << ", " << r["type"].get<std::string>();
  std::cout << ")\n";
  if (r.contains("note")) std::cout << r["note"].get<std::string>() << "\n";  // canopen: a new torque unit
}

void add_sdo_commands(CLI::App& device, CommonOptions& opts) {
  struct Args {
    std::string index, sub, value, type;
    int node = 0;  ///< 0: the one drive
  };
  auto args = std::make_shared<Args>();
  auto* sdo =
      device.add_subcommand("sdo", "canopen: read or write an object of the drive by SDO (commissioning)");
  sdo->require_subcommand(1);
  auto params = [args](bool with_value) {
    nlohmann::json p = {{"index", args->index}, {"sub", args->sub}};
    if (with_value) p["value"] = args->value;
    if (!args->type.empty()) p["type"] = args->type;
    if (args->node != 0) p["node"] = args->node;
    return p;
  };
  auto* read = sdo->add_subcommand("read", "INDEX SUB: e.g. sdo read 0x6041 0");
  auto* write = sdo->add_subcommand(
      "write",
      "INDEX SUB VALUE: e.g. sdo write 0x6065 0 2000 --type u32 (refused while enabled: what "
      "scales or bounds the torque)");
  for (auto* c : {read, write}) {
    add_common_options(*c, opts);
    c->add_option("index", args->index, "object index, e.g. 0x6041")->required();
    c->add_option("sub", args->sub, "sub-index, e.g. 0")->required();
  }
  write->add_option("value", args->value, "the value, decimal or 0x hex")->required();
  for (auto* c : {read, write})
    c->add_option("--type", args->type,
                  "u8, u16, u32, i8, i16, i32 or bool: needed for objects the driver does not know");
  for (auto* c : {read, write})
    c->add_option("--node", args->node, "with several drives on one bus (node_ids): the drive's node-ID")
        ->check(CLI::Range(1, 127));
  read->callback([&opts, params] {
    auto result = detail::call(opts, "device.sdo.read", params(false));
    if (opts.json) return detail::print_json(result);
    print_sdo(result);
  });
  write->callback([&opts, params] {
    auto result = detail::call(opts, "device.sdo.write", params(true));
    if (opts.json) return detail::print_json(result);
    print_sdo(result);
  });
}

/// "origin set at cycle 1234: the device's 0.785398 rad is now 0 (before: 0 rad, none); kept in FILE"
void print_zero(const nlohmann::json& r) {
  const std::string unit = r.value("unit", "");
  std::cout << "origin set at cycle " << detail::scalar(r["cycle"]) << ": the device's "
            << detail::scalar(r["origin"]) << " " << unit
            << " is now 0 (before: " << detail::scalar(r["previous_origin"]) << " " << unit << ", "
            << detail::scalar(r["previously"]) << ")\n";
  if (!r["kept"].is_null()) std::cout << "kept in " << detail::scalar(r["kept"]) << "\n";
  const auto& c = r["calibration"];
  if (c.is_object() && !c["note"].is_null()) std::cout << detail::scalar(c["note"]) << "\n";
}

void add_zero_command(CLI::App& device, CommonOptions& opts) {
  auto* zero = device.add_subcommand("zero",
                                     "make the device's current position the origin (device.zero; the scene "
                                     "restarts there, no torque step)");
  add_common_options(*zero, opts);
  zero->callback([&opts] {
    auto result = detail::call(opts, "device.zero");
    if (opts.json) return detail::print_json(result);
    print_zero(result);
  });
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
  add_sdo_commands(*cmd, opts);
  add_zero_command(*cmd, opts);
  cmd->callback([cmd, show] {
    if (cmd->get_subcommands().empty()) show();
  });
}

}  // namespace hapticctl
