#include "drivers/loopback/loopback_device.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "rpc/jsonrpc.hpp"
#include "rpc/params.hpp"
#include "world/gravity.hpp"

namespace hapticd::drivers::loopback {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;

LoopbackDevice::LoopbackDevice(const LoopbackConfig& config, const HandScript& hand) {
  simulators_.push_back(std::make_unique<simulation::PlantSimulator>(config, hand));
}

LoopbackDevice::LoopbackDevice(const LoopbackStage& stage) {
  if (stage.axes.empty() || stage.axes.size() > static_cast<std::size_t>(max_axes) ||
      stage.hands.size() != stage.axes.size())
    throw std::invalid_argument("loopback: a stage has 1 to " + std::to_string(max_axes) +
                                " axes, each with its hand");
  for (std::size_t i = 0; i < stage.axes.size(); ++i)
    simulators_.push_back(std::make_unique<simulation::PlantSimulator>(stage.axes[i], stage.hands[i]));
  if (stage.pantograph) {
    if (stage.axes.size() != 2) throw std::invalid_argument("loopback: a pantograph has two joints");
    pantograph_ = stage.pantograph;
    linkage_ = std::make_unique<simulation::PantographHand>(pantograph_->model.geometry, pantograph_->hand,
                                                            stage.axes[0].period_s);
    start_pantograph();
  }
}

LoopbackDevice::~LoopbackDevice() = default;

void LoopbackDevice::start_pantograph() {
  world::AxisVector x(2);
  x << pantograph_->start[0], pantograph_->start[1];
  const auto q = linkage_->kinematics().inverse(x);
  if (!q) throw std::invalid_argument("loopback: the pantograph's start is out of its reach");
  for (std::size_t i = 0; i < 2; ++i)
    simulators_[i]->set_initial_state((*q)(static_cast<Eigen::Index>(i)), 0.0);
}

std::unique_ptr<Device> make_loopback_device(const LoopbackConfig& config, const HandScript& hand) {
  return std::make_unique<Device>("loopback", std::make_unique<LoopbackDevice>(config, hand));
}

void LoopbackDevice::configure(const LoopContext& loop) {
  if (!(loop.period_s > 0.0) || !std::isfinite(loop.period_s)) {
    throw DeviceError("loopback: the loop period must be > 0 s", "period");
  }
  for (auto& axis : simulators_) {
    if (loop.period_s != axis->config().period_s) {
      // The plant is discretized for one period: rebuild it for the loop's.
      LoopbackConfig config = axis->config();
      config.period_s = loop.period_s;
      axis = std::make_unique<simulation::PlantSimulator>(config, axis->hand());
    }
  }
  if (linkage_) {
    linkage_->set_period(loop.period_s);
    start_pantograph();
  }
}

void LoopbackDevice::enable() {
  // The amplifier comes on with zero output, nothing stale.
  for (auto& axis : simulators_) axis->reset_actuator();
}

std::string LoopbackDevice::clear_fault() {
  std::string cleared;
  for (std::size_t i = 0; i < simulators_.size(); ++i) {
    const std::string faults = simulators_[i]->active_faults();
    simulators_[i]->clear_faults();
    if (faults.empty()) continue;
    if (!cleared.empty()) cleared += "; ";
    cleared += simulators_.size() == 1 ? faults : "axis " + std::to_string(i + 1) + ": " + faults;
  }
  return cleared;
}

void LoopbackDevice::disable() noexcept {
  // The amplifier is off: nothing is applied any more.
  for (auto& axis : simulators_) axis->reset_actuator();
}

IoResult LoopbackDevice::read(Reading& out) noexcept { return simulator().sense(out.position); }

/// The framework calls it only while enabled: disabled, the amplifier is
/// off and the plant does not advance (enable() empties the delay line).
IoResult LoopbackDevice::write(double force) noexcept { return simulator().step(force); }

namespace {
/// The worse of two results: a fault over an error over ok.
IoResult worse(IoResult a, IoResult b) noexcept { return static_cast<int>(a) >= static_cast<int>(b) ? a : b; }
}  // namespace

IoResult LoopbackDevice::read_axes(std::span<Reading> out) noexcept {
  IoResult result = IoResult::ok;
  for (std::size_t i = 0; i < out.size() && i < simulators_.size(); ++i)
    result = worse(result, simulators_[i]->sense(out[i].position));
  return result;
}

IoResult LoopbackDevice::write_axes(std::span<const double> forces) noexcept {
  IoResult result = IoResult::ok;
  if (linkage_ && forces.size() == 2) {
    // The hand on the handle, from the joints' true state at the period's start.
    const std::array<double, 2> q{simulators_[0]->body_position(), simulators_[1]->body_position()};
    const std::array<double, 2> qd{simulators_[0]->body_velocity(), simulators_[1]->body_velocity()};
    std::array<simulation::JointDrive, 2> drives{};
    linkage_->drives(q, qd, steps_++, drives);
    if (pantograph_->weight) add_link_weight(q, drives);
    for (std::size_t i = 0; i < 2; ++i) result = worse(result, simulators_[i]->step(forces[i], drives[i]));
    return result;
  }
  for (std::size_t i = 0; i < forces.size() && i < simulators_.size(); ++i)
    result = worse(result, simulators_[i]->step(forces[i]));
  return result;
}

/// The links' weight on the joints, -dV/dq (world/gravity.hpp), at the
/// period's start and held over it, as the hand's force is.
void LoopbackDevice::add_link_weight(const std::array<double, 2>& q,
                                     std::array<simulation::JointDrive, 2>& drives) const noexcept {
  world::AxisVector joints(2);
  joints << q[0], q[1];
  world::TaskState state;
  linkage_->kinematics().solve(joints, state);
  const world::AxisVector holding =
      world::pantograph_gravity_torques(linkage_->kinematics(), *pantograph_->weight, joints, state);
  drives[0].external -= holding(0);
  drives[1].external -= holding(1);
}

DeviceModel LoopbackDevice::model() const {
  const LoopbackConfig& c = simulator().config();
  DeviceModel m;
  m.motion = c.motion;
  m.effective_mass = c.total_mass();
  m.viscous_damping = c.total_damping();
  m.position_resolution = c.resolution();
  m.delay_periods = c.delay;
  if (c.plant == PlantKind::two_mass) m.plant = simulator().plant_model();
  m.sensor = c.sensor;
  m.source = "config";
  m.description = std::string(to_string(c.motion)) + ", " + std::string(to_string(c.plant));
  if (simulators_.size() == 1) return m;
  // A stage: every axis, and the lightest one in the one-axis fields.
  m.description = "linear, Cartesian stage of " + std::to_string(simulators_.size()) + " rigid axes";
  if (pantograph_) {
    const auto& g = pantograph_->model.geometry;
    m.pantograph = pantograph_->model;
    m.description = "pantograph: two rigid rotary joints, links " + to_text(ParameterValue(g.a1)) + ", " +
                    to_text(ParameterValue(g.a2)) + ", " + to_text(ParameterValue(g.a3)) + ", " +
                    to_text(ParameterValue(g.a4)) + ", " + to_text(ParameterValue(g.a5)) + " m" +
                    (pantograph_->weight ? ", in a vertical plane (link_masses)" : "");
  }
  for (const auto& axis : simulators_) {
    m.axes.push_back({axis->config().mass, axis->config().damping});
    if (axis->config().mass < m.effective_mass) {
      m.effective_mass = axis->config().mass;
      m.viscous_damping = axis->config().damping;
    }
  }
  return m;
}

DeviceHealth LoopbackDevice::health() const {
  DeviceHealth h;
  for (std::size_t i = 0; i < simulators_.size(); ++i) {
    const auto& axis = *simulators_[i];
    h.faulted = h.faulted || axis.faulted();
    const std::string faults = axis.active_faults();
    if (faults.empty()) continue;
    if (!h.last_error.empty()) h.last_error += "; ";
    h.last_error += simulators_.size() == 1 ? faults : "axis " + std::to_string(i + 1) + ": " + faults;
  }
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

namespace {

/// The axes a method acts on, [first, last): the `axis` member (1-based; a
/// stage only), else every axis.
std::pair<std::size_t, std::size_t> target_axes(std::string_view method, const json& params,
                                                std::size_t count) {
  if (!params.contains("axis")) return {0, count};
  const auto axis = static_cast<std::size_t>(rpc::integer_in(std::string(method), params, "axis", 1,
                                                             static_cast<std::int64_t>(count),
                                                             "an axis number, 1 to the device's axes"));
  return {axis - 1, axis};
}

/// params without the `axis` member.
json without_axis(json params) {
  params.erase("axis");
  return params;
}

}  // namespace

json LoopbackDevice::set_pantograph_hand(const json& params) {
  try {
    if (params.contains("axis")) {
      // A joint's own script, as on a stage.
      const auto [first, last] = target_axes("hand.set", params, simulators_.size());
      const std::string text = hand_text(without_axis(params));
      for (std::size_t i = first; i < last; ++i) simulators_[i]->set_hand(text);
    } else {
      linkage_->set_script(simulation::parse_task_hand_script(hand_text(params), pantograph_->start));
    }
  } catch (const std::invalid_argument& e) {
    throw RpcError(code::invalid_params, e.what());
  }
  json joints = json::array();
  for (const auto& axis : simulators_) joints.push_back(axis->hand().to_text());
  return json{{"hand", linkage_->script().to_text()}, {"joints", joints}};
}

std::vector<DeviceMethod> LoopbackDevice::methods() {
  const bool stage = simulators_.size() > 1;
  rpc::ParamMembers hand_keys = hand_members();
  rpc::ParamMembers fault_keys{{"kind", rpc::ParamType::string}, {"amount", rpc::ParamType::number}};
  if (stage) {
    hand_keys.push_back({"axis", rpc::ParamType::number});
    fault_keys.push_back({"axis", rpc::ParamType::number});
  }
  if (linkage_) {
    hand_keys.push_back({"direction", rpc::ParamType::string});
    hand_keys.push_back({"origin", rpc::ParamType::string});
  }
  DeviceMethod hand{"hand.set", true, "script the simulated hand (docs/protocol.md)",
                    [this, stage](const json& params) {
                      if (linkage_) return set_pantograph_hand(params);
                      const auto [first, last] = target_axes("hand.set", params, simulators_.size());
                      try {
                        const std::string text = hand_text(without_axis(params));
                        for (std::size_t i = first; i < last; ++i) simulators_[i]->set_hand(text);
                      } catch (const std::invalid_argument& e) {
                        throw RpcError(code::invalid_params, e.what());
                      }
                      if (!stage) return json{{"hand", simulator().hand().to_text()}};
                      json hands = json::array();
                      for (const auto& axis : simulators_) hands.push_back(axis->hand().to_text());
                      return json{{"hands", hands}};
                    },
                    hand_keys};
  DeviceMethod fault{"fault.inject", true, "make the simulated device fail (docs/protocol.md)",
                     [this](const json& params) {
                       const std::string kind = params.value("kind", std::string());
                       const auto which = simulation::parse_fault(kind);
                       if (!which) {
                         throw RpcError(code::invalid_params,
                                        "fault.inject: unknown kind " + rpc::quoted_name(kind) +
                                            "; accepted: " + std::string(simulation::fault_names()));
                       }
                       const auto [first, last] = target_axes("fault.inject", params, simulators_.size());
                       std::int64_t amount = 0;
                       for (std::size_t i = first; i < last; ++i)
                         amount = fault_amount(*which, params, simulators_[i]->encoder_offset());
                       for (std::size_t i = first; i < last; ++i)
                         simulators_[i]->inject_fault(*which, amount);
                       return json{{"injected", kind}, {"amount", amount}};
                     },
                     // amount: any number here, so that fault_amount() names its own range
                     // for 2^64-1 or 1.5, not int64's
                     fault_keys};
  return {std::move(hand), std::move(fault)};
}

}  // namespace hapticd::drivers::loopback
