#include "drivers/canopen/canopen_device.hpp"

#include <cstdio>
#include <numbers>

#include "drivers/canopen/commissioning.hpp"
#include "rpc/jsonrpc.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;

namespace {

/// An index, sub-index or value given as a number or as text ("0x6041").
std::int64_t integer_param(const json& params, const char* name, bool hex_text_only_unsigned = true) {
  (void)hex_text_only_unsigned;
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

void only_members(const json& params, std::initializer_list<const char*> accepted, const char* method) {
  if (!params.is_object())
    throw RpcError(code::invalid_params, std::string(method) + ": params must be an object");
  for (const auto& [key, value] : params.items()) {
    bool ok = false;
    std::string list;
    for (const char* a : accepted) {
      ok = ok || key == a;
      list += (list.empty() ? "" : ", ") + std::string(a);
    }
    if (!ok)
      throw RpcError(code::invalid_params,
                     std::string(method) + ": unknown member '" + key + "'; accepted: " + list);
  }
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

CanopenDevice::CanopenDevice(CanopenConfig config) : config_(std::move(config)) { validate(config_); }

CanopenDevice::~CanopenDevice() { close(); }

void CanopenDevice::configure(const LoopContext& loop) {
  auto session = std::make_unique<CanopenSession>(config_);
  session->set_stop(loop.stop);
  session->configure(loop.period_s);
  session_ = std::move(session);
}

void CanopenDevice::enable() { session_->enable(); }

std::string CanopenDevice::clear_fault() { return session_->clear_fault(); }

void CanopenDevice::disable() noexcept { session_->disable(); }

void CanopenDevice::close() noexcept {
  if (session_) session_->close();
  session_.reset();
}

IoResult CanopenDevice::read(Reading& out) noexcept { return session_->read(out); }

IoResult CanopenDevice::write(double force) noexcept { return session_->write(force); }

DeviceModel CanopenDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  const double unit = config_.motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  m.position_resolution = unit / config_.counts_per_unit;
  m.delay_periods = 1;  // the RPDO sent before SYNC n acts at SYNC n; the position is from SYNC n-1
  m.source = "config";
  const DriveIdentity& id = session_->setup().identity;
  m.description = "CiA 402 drive, node " + std::to_string(config_.node_id) + " (vendor " +
                  world::text::format_hex(id.vendor_id, 8) + ", product " +
                  world::text::format_hex(id.product_code, 8) + "), cyclic synchronous torque";
  for (const std::string& note : session_->setup().notes) m.description += "; " + note;
  return m;
}

DeviceHealth CanopenDevice::health() const {
  DeviceHealth s;
  if (!session_) return s;
  const SessionStatus st = session_->status();
  s.faulted = st.faulted;
  s.fault_reason = st.fault_reason;
  const CyclicCounters& c = st.counters;
  s.counters = {{"periods", c.periods},
                {"tpdos", c.tpdos},
                {"late_tpdos", c.late_tpdos},
                {"short_tpdos", c.short_tpdos},
                {"emcys", c.emcys},
                {"error_frames", c.error_frames},
                {"drive_heartbeats", c.drive_heartbeats},
                {"tx_dropped", c.tx_dropped},
                {"malformed_frames", c.malformed_frames},
                {"malformed_messages", c.malformed_messages},
                {"sdo_answers_dropped", st.sdo_answers_dropped},
                {"rated_torque_mnm", st.rated_torque_mnm},
                {"statusword", st.statusword},
                {"controlword", st.controlword}};
  return s;
}

std::vector<DeviceMethod> CanopenDevice::methods() {
  DeviceMethod read{"device.sdo.read", false,
                    "read an object of the drive by SDO: index, sub [, type] (commissioning)",
                    [this](const json& params) {
                      only_members(params, {"index", "sub", "type"}, "device.sdo.read");
                      const cia301::ObjectAddress a = address_param(params);
                      const auto type = type_param(params);
                      if (!session_) throw RpcError(code::refused, "the drive is not configured");
                      try {
                        return to_json(session_->sdo_read(a, type));
                      } catch (const SdoError& e) {
                        throw RpcError(code::refused, e.what());
                      }
                    }};
  DeviceMethod write{
      "device.sdo.write", true,
      "write an object of the drive by SDO: index, sub, value [, type]; what scales or bounds the torque "
      "only while disabled",
      [this](const json& params) {
        only_members(params, {"index", "sub", "value", "type"}, "device.sdo.write");
        const cia301::ObjectAddress a = address_param(params);
        const std::int64_t value = integer_param(params, "value");
        const auto type = type_param(params);
        if (!session_) throw RpcError(code::refused, "the drive is not configured");
        try {
          return to_json(session_->sdo_write(a, value, type));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::refused, e.what());
        } catch (const SdoError& e) {
          throw RpcError(code::refused, e.what());
        } catch (const SetupError& e) {  // 0x6076 read back: unreadable, or against rated_torque
          throw RpcError(code::refused, e.what());
        }
      }};
  // Numbers or text ("0x6041"), read by integer_param(); the daemon checks
  // the members and their types before the handler runs.
  const rpc::ParamMember index{"index", rpc::ParamType::integer_or_string};
  const rpc::ParamMember sub{"sub", rpc::ParamType::integer_or_string};
  const rpc::ParamMember type{"type", rpc::ParamType::string};
  read.members = {index, sub, type};
  write.members = {index, sub, {"value", rpc::ParamType::integer_or_string}, type};
  return {read, write};
}

}  // namespace hapticd::drivers::canopen
