// The canopen hooks' commissioning part: device.sdo.read and
// device.sdo.write, and the 0x6076 read-back that keeps the torque unit the
// drive's (README.md, "Commissioning"); with several drives on one bus,
// device.sdo.read of the node named.

#include <cmath>

#include "drivers/canopen/402/objects.hpp"
#include "drivers/canopen/canopen_bus_device.hpp"
#include "drivers/canopen/canopen_device.hpp"
#include "drivers/canopen/commissioning.hpp"
#include "rpc/jsonrpc.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;

namespace {

/// An index, sub-index or value given as a number or as text ("0x6041").
std::int64_t integer_param(const json& params, const char* name) {
  if (!params.contains(name)) throw RpcError(code::invalid_params, std::string("missing '") + name + "'");
  const json& v = params[name];
  if (v.is_number_integer()) return v.get<std::int64_t>();
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (d == std::floor(d) && std::abs(d) < 9e15) return static_cast<std::int64_t>(d);
  }
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    try {
      std::size_t used = 0;
      const long long parsed = std::stoll(s, &used, 0);
      if (used == s.size()) return parsed;
    } catch (const std::exception&) {
    }
  }
  throw RpcError(code::invalid_params, std::string("'") + name + "' = " + v.dump() +
                                           " is not an integer (decimal, or hex with 0x)");
}

cia301::ObjectAddress address_param(const json& params) {
  const std::int64_t index = integer_param(params, "index");
  const std::int64_t sub = params.contains("sub") ? integer_param(params, "sub") : 0;
  if (index < 0 || index > 0xFFFF) throw RpcError(code::invalid_params, "index must be 0x0000..0xFFFF");
  if (sub < 0 || sub > 0xFF) throw RpcError(code::invalid_params, "sub must be 0..255");
  return {static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub)};
}

std::optional<cia301::DataType> type_param(const json& params) {
  if (!params.contains("type")) return std::nullopt;
  const json& t = params["type"];
  const auto type = t.is_string() ? cia301::parse_data_type(t.get<std::string>()) : std::nullopt;
  if (!type)
    throw RpcError(code::invalid_params,
                   "type " + t.dump() + " is not one of " + std::string(cia301::accepted_data_type_names()));
  return type;
}

/// The node-ID of one of several drives: required, 1..127 (the device says whether it is one of its).
std::uint8_t node_param(const json& params, const std::vector<std::uint8_t>& nodes) {
  std::string accepted;
  for (const std::uint8_t n : nodes) accepted += (accepted.empty() ? "" : ", ") + std::to_string(n);
  if (!params.contains("node"))
    throw RpcError(code::invalid_params,
                   "missing 'node': several drives share this bus; name one of node_ids " + accepted);
  const std::int64_t node = integer_param(params, "node");
  if (node < 1 || node > 127)
    throw RpcError(code::invalid_params,
                   "node " + std::to_string(node) + " is no node-ID (1..127); accepted: one of " + accepted);
  return static_cast<std::uint8_t>(node);
}

json to_json(const SdoAccess& a) {
  json j = {{"index", world::text::format_hex(a.address.index, 4)},
            {"sub", a.address.sub},
            {"raw", world::text::format_hex(a.raw, 8)},
            {"value", a.value}};
  j["type"] = a.type ? json(std::string(cia301::short_name(*a.type))) : json(nullptr);
  j["name"] = a.name;
  if (!a.note.empty()) j["note"] = a.note;
  return j;
}

}  // namespace

TorqueUnitCheck check_torque_unit(SdoClient& sdo, const CanopenConfig& config, std::uint32_t before_mnm,
                                  bool fault_if_changed) {
  TorqueUnitChange change;
  change.before_mnm = before_mnm;
  change.fault = fault_if_changed;
  std::string problem;
  try {
    const auto drive = read_rated_torque(sdo);
    change.after_mnm = torque_unit(drive, static_cast<std::uint32_t>(std::llround(config.rated_torque * 1e3)),
                                   config.node_id);
  } catch (const SdoError& e) {
    problem = std::string(
                  "cannot read back 0x6076 motor rated torque, the unit of every torque hapticd "
                  "sends: ") +
              e.what();
  } catch (const SetupError& e) {
    problem = e.what();
  }
  if (!problem.empty() && !fault_if_changed) throw SetupError(problem, "rated_torque");
  if (problem.empty() && change.after_mnm == before_mnm) return {};
  if (problem.empty())
    change.force_per_permille = canopen::scaling(config, change.after_mnm).force_per_permille;
  else
    change.after_mnm = 0;  // enabled and unreadable: a fault, the scale unchanged
  return {change, problem};
}

std::string torque_unit_note(std::uint8_t node, const TorqueUnitChange& change, const std::string& scaled,
                             const std::string& held) {
  return "node " + std::to_string(node) + "'s 0x6076 motor rated torque is now " +
         std::to_string(change.after_mnm) + " mN m (was " + std::to_string(change.before_mnm) +
         "): hapticd scales " + scaled + " by it" +
         (change.fault ? "; " + held + " (fault latched) until fault clear" : " from now on");
}

std::string CanopenDevice::recheck_torque_unit(FrameLink& link, bool fault_if_changed) {
  if (!setup_.rated_torque_from_drive) return "";              // no 0x6076: the config's rated_torque stands
  SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);  // gives way to SIGTERM
  const TorqueUnitCheck check = check_torque_unit(sdo, config_, rated_torque_mnm(), fault_if_changed);
  if (!check.change) return "";
  if (!unit_changes_->try_push(*check.change))
    throw SetupError("the loop has not taken the last torque unit yet", "");
  if (!check.problem.empty())
    throw SetupError(check.problem + ": torque held at zero (fault latched)", "rated_torque");
  rated_torque_mnm_.store(check.change->after_mnm, std::memory_order_release);
  return torque_unit_note(config_.node_id, *check.change, "every torque",
                          "the drive was enabled: torque held at zero");
}

SdoAccess CanopenDevice::sdo_read(cia301::ObjectAddress address, std::optional<cia301::DataType> type) {
  if (!exchange_) throw std::invalid_argument("the drive is not configured");
  std::lock_guard lock(sdo_mutex_);
  std::uint32_t raw = 0;
  with_sdo_link(enabled_.load(std::memory_order_acquire), [&](FrameLink& link) {
    SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
    raw = sdo.read(address);
  });
  return describe_access(address, raw, type);
}

CheckedWrite checked_write(cia301::ObjectAddress address, std::int64_t value,
                           std::optional<cia301::DataType> type, bool enabled) {
  if (enabled) {
    if (const auto why = refused_while_enabled(address)) throw std::invalid_argument(*why);
  }
  const cia301::DataType t = write_type(address, type);
  const auto raw = cia301::to_raw(t, value);
  if (!raw)
    throw std::invalid_argument(std::to_string(value) + " does not fit " +
                                std::string(cia301::short_name(t)) + " (" + cia301::to_string(address) + ")");
  return {t, *raw};
}

std::string write_and_recheck(SdoClient& sdo, cia301::ObjectAddress address, const CheckedWrite& write,
                              const std::function<std::string()>& recheck) {
  // Any write may change 0x6076 (a restore, a manufacturer's motor object).
  try {
    sdo.write(address, write.raw, cia301::size_of(write.type));
  } catch (const SdoError& e) {
    std::string note;
    try {
      note = recheck();
    } catch (const SetupError& unreadable) {
      throw SetupError(std::string(e.what()) + "; " + unreadable.what(), unreadable.key());
    }
    if (note.empty()) throw;
    throw SdoError(std::string(e.what()) + "; " + note, e.outcome());
  }
  return recheck();
}

SdoAccess CanopenDevice::sdo_write(cia301::ObjectAddress address, std::int64_t value,
                                   std::optional<cia301::DataType> type) {
  if (!exchange_) throw std::invalid_argument("the drive is not configured");
  const CheckedWrite write = checked_write(address, value, type, enabled_.load(std::memory_order_acquire));
  std::lock_guard lock(sdo_mutex_);
  const bool was_enabled = enabled_.load(std::memory_order_acquire);
  SdoAccess a = describe_access(address, write.raw, write.type);
  with_sdo_link(was_enabled, [&](FrameLink& link) {
    SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
    a.note = write_and_recheck(sdo, address, write, [&] { return recheck_torque_unit(link, was_enabled); });
  });
  return a;
}

std::vector<DeviceMethod> CanopenDevice::methods() {
  // The daemon refuses a member these do not declare, or a wrong type, before a handler runs.
  DeviceMethod read{"device.sdo.read", false,
                    "read an object of the drive by SDO: index, sub [, type] (commissioning)",
                    [this](const json& params) {
                      const cia301::ObjectAddress a = address_param(params);
                      const auto type = type_param(params);
                      try {
                        return to_json(sdo_read(a, type));
                      } catch (const std::invalid_argument& e) {  // not configured
                        throw RpcError(code::refused, e.what());
                      } catch (const SdoError& e) {
                        throw RpcError(code::refused, e.what());
                      }
                    }};
  DeviceMethod write{
      "device.sdo.write", true,
      "write an object of the drive by SDO: index, sub, value [, type]; what scales or bounds the torque "
      "only while disabled",
      [this](const json& params) {
        const cia301::ObjectAddress a = address_param(params);
        const std::int64_t value = integer_param(params, "value");
        const auto type = type_param(params);
        try {
          return to_json(sdo_write(a, value, type));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::refused, e.what());
        } catch (const SdoError& e) {
          throw RpcError(code::refused, e.what());
        } catch (const SetupError& e) {  // 0x6076 read back: unreadable, or against rated_torque
          throw RpcError(code::refused, e.what());
        }
      }};
  // Numbers or text ("0x6041"), read by integer_param().
  const rpc::ParamMember index{"index", rpc::ParamType::integer_or_string};
  const rpc::ParamMember sub{"sub", rpc::ParamType::integer_or_string};
  const rpc::ParamMember type{"type", rpc::ParamType::string};
  read.members = {index, sub, type};
  write.members = {index, sub, {"value", rpc::ParamType::integer_or_string}, type};
  return {read, write};
}

std::vector<DeviceMethod> CanopenBusDevice::methods() {
  // As one drive's, with the node named; the answer names it too.
  const auto refused = [](const auto& call) {
    try {
      return call();
    } catch (const std::invalid_argument& e) {  // not one of ours, no loop, refused while enabled
      throw RpcError(code::refused, e.what());
    } catch (const SdoError& e) {
      throw RpcError(code::refused, e.what());
    } catch (const SetupError& e) {  // 0x6076 read back: unreadable, or against rated_torque
      throw RpcError(code::refused, e.what());
    }
  };
  DeviceMethod read{
      "device.sdo.read", false,
      "read an object of one drive on the bus by SDO: node, index, sub [, type] (commissioning)",
      [this, refused](const json& params) {
        const std::uint8_t node = node_param(params, config_.node_ids);
        const cia301::ObjectAddress a = address_param(params);
        const auto type = type_param(params);
        json j = refused([&] { return to_json(sdo_read(node, a, type)); });
        j["node"] = node;
        return j;
      }};
  DeviceMethod write{"device.sdo.write", true,
                     "write an object of one drive on the bus by SDO: node, index, sub, value [, type]; what "
                     "scales or bounds the torque only while disabled",
                     [this, refused](const json& params) {
                       const std::uint8_t node = node_param(params, config_.node_ids);
                       const cia301::ObjectAddress a = address_param(params);
                       const std::int64_t value = integer_param(params, "value");
                       const auto type = type_param(params);
                       json j = refused([&] { return to_json(sdo_write(node, a, value, type)); });
                       j["node"] = node;
                       return j;
                     }};
  const rpc::ParamMember node{"node", rpc::ParamType::integer_or_string};
  const rpc::ParamMember index{"index", rpc::ParamType::integer_or_string};
  const rpc::ParamMember sub{"sub", rpc::ParamType::integer_or_string};
  const rpc::ParamMember type{"type", rpc::ParamType::string};
  read.members = {node, index, sub, type};
  write.members = {node, index, sub, {"value", rpc::ParamType::integer_or_string}, type};
  return {read, write};
}

}  // namespace hapticd::drivers::canopen
