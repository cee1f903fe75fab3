#include "drivers/loopback/loopback_device.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "rpc/jsonrpc.hpp"
#include "rpc/params.hpp"

namespace hapticd::drivers::loopback {

namespace {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;

constexpr bool valid_from(DeviceState state, bool needs_enabled) noexcept {
  return needs_enabled ? state == DeviceState::enabled : state != DeviceState::closed;
}

}  // namespace

LoopbackDevice::LoopbackDevice(const LoopbackConfig& config, const HandScript& hand)
    : simulator_(std::make_unique<simulation::PlantSimulator>(config, hand)) {}

void LoopbackDevice::require(bool condition, const char* what) const {
  if (!condition) {
    throw std::logic_error(std::string("loopback: ") + what + " while " +
                           std::string(to_string(state_.load(std::memory_order_acquire))));
  }
}

void LoopbackDevice::configure(const LoopContext& loop) {
  require(state_.load(std::memory_order_acquire) == DeviceState::closed, "configure()");
  if (!(loop.period_s > 0.0) || !std::isfinite(loop.period_s)) {
    throw DeviceError("loopback: the loop period must be > 0 s", "period");
  }
  if (loop.period_s != simulator_->config().period_s) {
    // The plant is discretized for one period: rebuild it for the loop's.
    LoopbackConfig config = simulator_->config();
    config.period_s = loop.period_s;
    simulator_ = std::make_unique<simulation::PlantSimulator>(config, simulator_->hand());
  }
  state_.store(DeviceState::configured, std::memory_order_release);
}

void LoopbackDevice::enable() {
  const DeviceState s = state_.load(std::memory_order_acquire);
  require(s == DeviceState::configured || s == DeviceState::enabled, "enable()");
  simulator_->reset_actuator();  // the amplifier comes on with zero output, nothing stale
  state_.store(DeviceState::enabled, std::memory_order_release);
}

std::string LoopbackDevice::clear_fault() {
  require(state_.load(std::memory_order_acquire) != DeviceState::closed, "clear_fault()");
  std::string cleared = simulator_->active_faults();
  simulator_->clear_faults();
  return cleared;
}

void LoopbackDevice::disable() noexcept {
  DeviceState expected = DeviceState::enabled;
  if (state_.compare_exchange_strong(expected, DeviceState::configured, std::memory_order_acq_rel)) {
    simulator_->reset_actuator();  // the amplifier is off: nothing is applied any more
  }
}

void LoopbackDevice::close() noexcept {
  disable();
  state_.store(DeviceState::closed, std::memory_order_release);
}

IoResult LoopbackDevice::read(Reading& out) noexcept {
  if (!valid_from(state_.load(std::memory_order_acquire), false)) {
    refused_reads_.fetch_add(1, std::memory_order_relaxed);
    return IoResult::error;
  }
  return simulator_->sense(out.position);
}

IoResult LoopbackDevice::write(double force) noexcept {
  // Disabled: the amplifier is off, the command is refused and the plant
  // does not advance (enable() empties the delay line).
  if (!valid_from(state_.load(std::memory_order_acquire), true)) {
    refused_writes_.fetch_add(1, std::memory_order_relaxed);
    return IoResult::error;
  }
  return simulator_->step(force);
}

void LoopbackDevice::set_initial_state(double position, double velocity) {
  if (state_.load(std::memory_order_acquire) == DeviceState::enabled) {
    throw std::logic_error("loopback: set_initial_state() only while disabled");
  }
  simulator_->set_initial_state(position, velocity);
}

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

DeviceStatus LoopbackDevice::status() const {
  const auto counters = simulator_->counters();
  DeviceStatus s;
  s.state = state_.load(std::memory_order_acquire);
  if (s.state != DeviceState::closed && simulator_->faulted()) s.state = DeviceState::fault;
  s.read_errors = counters.read_errors + refused_reads_.load(std::memory_order_relaxed);
  s.write_errors = counters.write_errors + refused_writes_.load(std::memory_order_relaxed);
  s.faults = counters.faults;
  s.last_error = simulator_->active_faults();
  if (simulator_->faulted()) s.fault_reason = "injected fault: the simulated amplifier is off";
  return s;
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
