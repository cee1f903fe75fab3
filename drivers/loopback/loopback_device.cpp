#include "drivers/loopback/loopback_device.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "rpc/jsonrpc.hpp"
#include "rpc/params.hpp"

namespace hapticd::drivers::loopback {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;

LoopbackDevice::LoopbackDevice(const LoopbackConfig& config, const HandScript& hand)
    : simulator_(std::make_unique<simulation::PlantSimulator>(config, hand)) {}

std::unique_ptr<Device> make_loopback_device(const LoopbackConfig& config, const HandScript& hand) {
  return std::make_unique<Device>("loopback", std::make_unique<LoopbackDevice>(config, hand));
}

void LoopbackDevice::configure(const LoopContext& loop) {
  if (!(loop.period_s > 0.0) || !std::isfinite(loop.period_s)) {
    throw DeviceError("loopback: the loop period must be > 0 s", "period");
  }
  if (loop.period_s != simulator_->config().period_s) {
    // The plant is discretized for one period: rebuild it for the loop's.
    LoopbackConfig config = simulator_->config();
    config.period_s = loop.period_s;
    simulator_ = std::make_unique<simulation::PlantSimulator>(config, simulator_->hand());
  }
}

void LoopbackDevice::enable() {
  simulator_->reset_actuator();  // the amplifier comes on with zero output, nothing stale
}

std::string LoopbackDevice::clear_fault() {
  std::string cleared = simulator_->active_faults();
  simulator_->clear_faults();
  return cleared;
}

void LoopbackDevice::disable() noexcept {
  simulator_->reset_actuator();  // the amplifier is off: nothing is applied any more
}

IoResult LoopbackDevice::read(Reading& out) noexcept { return simulator_->sense(out.position); }

/// The framework calls it only while enabled: disabled, the amplifier is
/// off and the plant does not advance (enable() empties the delay line).
IoResult LoopbackDevice::write(double force) noexcept { return simulator_->step(force); }

DeviceModel LoopbackDevice::model() const {
  const LoopbackConfig& c = simulator_->config();
  DeviceModel m;
  m.motion = c.motion;
  m.effective_mass = c.total_mass();
  m.viscous_damping = c.total_damping();
  m.position_resolution = c.resolution();
  m.delay_periods = c.delay;
  if (c.plant == PlantKind::two_mass) m.plant = simulator_->plant_model();
  m.sensor = c.sensor;
  m.source = "config";
  m.description = std::string(to_string(c.motion)) + ", " + std::string(to_string(c.plant));
  return m;
}

DeviceHealth LoopbackDevice::health() const {
  DeviceHealth h;
  h.faulted = simulator_->faulted();
  h.last_error = simulator_->active_faults();
  if (h.faulted) h.fault_reason = "injected fault: the simulated amplifier is off";
  return h;
}

namespace {

/// hand.set's members: "text", or the script's keys (scalars).
rpc::ParamMembers hand_members() {
  rpc::ParamMembers members{{"text", rpc::ParamType::string}};
  for (const auto key : simulation::hand_script_keys())
    members.push_back({std::string(key), rpc::ParamType::scalar});
  return members;
}

/// The script text from hand.set's params: "text", or each member as key=value.
std::string hand_text(const json& params) {
  if (params.contains("text")) {
    if (params.size() > 1) {
      throw RpcError(code::invalid_params,
                     "hand.set: send either \"text\" or the script's keys as members, not both");
    }
    return params["text"].get<std::string>();
  }
  std::string text;
  for (const auto& [k, v] : params.items()) {
    const std::string value = v.is_string() ? v.get<std::string>() : v.dump();
    // The script is key=value text: a space or '=' inside a value would
    // smuggle in another key.
    if (value.find_first_of(" \t\n\r=") != std::string::npos) {
      throw RpcError(code::invalid_params, "hand.set: " + k + " = " + rpc::quoted_name(value) +
                                               " may not contain spaces, line breaks or '='");
    }
    text += k + "=" + value + " ";
  }
  return text;
}

/// The total encoder-jump offset stays within +/-2^53 counts: a double holds
/// every count exactly up to there, and no sum of jumps wraps the int64.
constexpr std::int64_t max_encoder_offset = std::int64_t{1} << 53;

/// fault.inject's amount: for encoder-jump the jump in counts (required,
/// the offset it leads to within +/-2^53); else periods, -1 = until cleared.
std::int64_t fault_amount(Fault which, const json& params, std::int64_t offset_now) {
  if (which == Fault::encoder_jump) {
    if (!params.contains("amount")) {
      throw RpcError(code::invalid_params,
                     "fault.inject: encoder-jump needs amount (the jump in encoder "
                     "counts, e.g. amount=1000 or amount=-1000)");
    }
    const std::int64_t amount = rpc::integer_in("fault.inject", params, "amount", -max_encoder_offset,
                                                max_encoder_offset, "counts (encoder-jump)");
    if (const std::int64_t total = offset_now + amount;
        total > max_encoder_offset || total < -max_encoder_offset) {
      throw RpcError(code::invalid_params,
                     "fault.inject: encoder-jump by " + std::to_string(amount) +
                         " counts would take the offset from " + std::to_string(offset_now) + " to " +
                         std::to_string(total) +
                         " counts; the offset stays within -9007199254740992 to 9007199254740992 (2^53; "
                         "fault.clear resets it)",
                     json{{"member", "amount"},
                          {"minimum", -max_encoder_offset - offset_now},
                          {"maximum", max_encoder_offset - offset_now}});
    }
    return amount;
  }
  if (!params.contains("amount")) return -1;
  // Not `== -1`: nlohmann::json compares 2^64-1 (unsigned) equal to -1.
  if (const json& a = params["amount"];
      a.is_number_integer() && !a.is_number_unsigned() && a.get<std::int64_t>() == -1)
    return -1;
  return rpc::integer_in("fault.inject", params, "amount", 1, std::numeric_limits<std::int64_t>::max(),
                         "periods, or -1 (until fault.clear)");
}

}  // namespace

std::vector<DeviceMethod> LoopbackDevice::methods() {
  DeviceMethod hand{"hand.set", true, "script the simulated hand (docs/protocol.md)",
                    [this](const json& params) {
                      try {
                        simulator_->set_hand(hand_text(params));
                      } catch (const std::invalid_argument& e) {
                        throw RpcError(code::invalid_params, e.what());
                      }
                      return json{{"hand", simulator_->hand().to_text()}};
                    },
                    hand_members()};
  DeviceMethod fault{"fault.inject",
                     true,
                     "make the simulated device fail (docs/protocol.md)",
                     [this](const json& params) {
                       const std::string kind = params.value("kind", std::string());
                       const auto which = simulation::parse_fault(kind);
                       if (!which) {
                         throw RpcError(code::invalid_params,
                                        "fault.inject: unknown kind " + rpc::quoted_name(kind) +
                                            "; accepted: " + std::string(simulation::fault_names()));
                       }
                       const std::int64_t amount = fault_amount(*which, params, simulator_->encoder_offset());
                       simulator_->inject_fault(*which, amount);
                       return json{{"injected", kind}, {"amount", amount}};
                     },
                     // amount: any number here, so that fault_amount() names its own range
                     // for 2^64-1 or 1.5, not int64's
                     {{"kind", rpc::ParamType::string}, {"amount", rpc::ParamType::number}}};
  return {std::move(hand), std::move(fault)};
}

}  // namespace hapticd::drivers::loopback
