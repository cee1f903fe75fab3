#include "daemon/device_model.hpp"

#include <cmath>
#include <map>
#include <optional>

#include "analysis/critical_stiffness.hpp"
#include "world/scene_catalog.hpp"
#include "world/text.hpp"

namespace hapticd::daemon {

namespace {

using config::ConfigError;
using config::Parameter;
using config::ParameterList;
using config::SourcePosition;

std::string number(double value) {
  return world::text::format_significant(value, world::text::precision::message);
}

/// The keys by name, each checked once.
class Keys {
 public:
  Keys(const ParameterList& keys, SourcePosition where) : where_(std::move(where)) {
    for (const Parameter& p : keys) by_name_[p.key] = &p;
  }

  [[noreturn]] void fail(const Parameter* p, const std::string& key, const std::string& message) const {
    throw ConfigError(p != nullptr ? p->where : where_, "model." + key, message);
  }

  const Parameter* find(const std::string& key) const {
    const auto it = by_name_.find(key);
    return it == by_name_.end() ? nullptr : it->second;
  }

  const Parameter& require(const std::string& key, const std::string& accepted) const {
    const Parameter* p = find(key);
    if (p == nullptr) fail(nullptr, key, "model." + key + " is missing; accepted: " + accepted);
    return *p;
  }

  std::string text(const std::string& key, const std::string& accepted, std::optional<std::string> def = {}) {
    used_.push_back(key);
    const Parameter* p = def && !find(key) ? nullptr : &require(key, accepted);
    if (p == nullptr) return *def;
    const auto* s = std::get_if<std::string>(&p->value);
    if (s == nullptr)
      fail(p, key, "model." + key + " = " + config::to_toml(p->value) + "; accepted: " + accepted);
    return *s;
  }

  double number_in(const std::string& key, double low, bool low_inclusive, double high,
                   std::optional<double> def = {}) {
    used_.push_back(key);
    const std::string accepted =
        std::string("a number ") + (low_inclusive ? ">= " : "> ") + number(low) + " and <= " + number(high);
    if (def && !find(key)) return *def;
    const Parameter& p = require(key, accepted);
    const auto* v = std::get_if<double>(&p.value);
    const bool above = v != nullptr && (low_inclusive ? *v >= low : *v > low);
    if (v == nullptr || !above || !(*v <= high)) {
      fail(&p, key, "model." + key + " = " + config::to_toml(p.value) + " is not accepted; " + accepted);
    }
    return *v;
  }

  /// Every key not read is an error naming the accepted ones.
  void no_others(const std::string& plant) const {
    for (const auto& [name, p] : by_name_) {
      bool known = false;
      for (const auto& u : used_) known = known || u == name;
      if (known) continue;
      std::string accepted;
      for (const auto& u : used_) accepted += (accepted.empty() ? "" : ", ") + u;
      fail(p, name, "unknown key '" + name + "' for plant = \"" + plant + "\"; accepted: " + accepted);
    }
  }

 private:
  SourcePosition where_;
  std::map<std::string, const Parameter*> by_name_;
  std::vector<std::string> used_;
};

}  // namespace

drivers::DeviceModel model_from_keys(const ParameterList& keys, const drivers::DeviceModel& driver,
                                     double period_s, std::string source, const SourcePosition& where) {
  namespace r = world::parameter_range;
  Keys k(keys, where);
  drivers::DeviceModel m;
  const std::string plant = k.text("plant", "\"rigid\" or \"two-mass\"");
  if (plant != "rigid" && plant != "two-mass") {
    k.fail(k.find("plant"), "plant", "model.plant = \"" + plant + "\"; accepted: \"rigid\" or \"two-mass\"");
  }
  const std::string motion = k.text("motion", "\"rotary\" or \"linear\"");
  if (motion != drivers::to_string(driver.motion)) {
    k.fail(k.find("motion"), "motion",
           "model.motion = \"" + motion + "\" does not match the device, which is " +
               std::string(drivers::to_string(driver.motion)));
  }
  m.motion = driver.motion;
  const double period = k.number_in("period", 0.0, false, 1.0);
  if (std::abs(period - period_s) > 1e-9 * period_s) {
    k.fail(k.find("period"), "period",
           "the model was identified at a period of " + number(period * 1e3) + " ms and the loop runs at " +
               number(period_s * 1e3) +
               " ms: its delay is counted in periods; identify again at this period");
  }
  const double delay = k.number_in("delay", 0.0, true, analysis::max_delay_periods, 0.0);
  if (std::trunc(delay) != delay) {
    k.fail(k.find("delay"), "delay", "model.delay = " + number(delay) + " is not a whole number of periods");
  }
  m.delay_periods = static_cast<int>(delay);
  k.number_in("coulomb", 0.0, true, r::max_force, 0.0);  // recorded; the gate's models are linear
  if (plant == "rigid") {
    m.effective_mass = k.number_in("mass", r::min_mass, true, r::max_mass);
    m.viscous_damping = k.number_in("damping", 0.0, true, r::max_damping);
  } else {
    world::TwoMassPlant p;
    p.motor_mass = k.number_in("motor_mass", r::min_mass, true, r::max_mass);
    p.body_mass = k.number_in("body_mass", r::min_mass, true, r::max_mass);
    p.motor_damping = k.number_in("motor_damping", 0.0, true, r::max_damping);
    p.body_damping = k.number_in("body_damping", 0.0, true, r::max_damping);
    p.cable_stiffness = k.number_in("cable_stiffness", 0.0, false, r::max_stiffness);
    p.cable_damping = k.number_in("cable_damping", 0.0, true, r::max_damping);
    const std::string sensor = k.text("sensor", "\"motor\" or \"body\"", std::string("motor"));
    const auto parsed = world::parse_sensor(sensor);
    if (!parsed)
      k.fail(k.find("sensor"), "sensor",
             "model.sensor = \"" + sensor + "\"; accepted: \"motor\" or \"body\"");
    m.plant = p.model();
    m.sensor = *parsed;
    m.effective_mass = p.total_mass();
    m.viscous_damping = p.total_damping();
  }
  k.no_others(plant);
  m.position_resolution = driver.position_resolution;
  m.source = std::move(source);
  m.description = motion + ", " + plant + ", identified";
  return m;
}

ParameterList keys_from_json(const nlohmann::json& object) {
  if (!object.is_object()) throw std::invalid_argument("model must be an object of key: value");
  ParameterList out;
  for (const auto& [key, value] : object.items()) {
    config::ParameterValue v;
    if (value.is_number()) {
      v = value.get<double>();
    } else if (value.is_string()) {
      v = value.get<std::string>();
    } else if (value.is_boolean()) {
      v = value.get<bool>();
    } else {
      throw std::invalid_argument("model." + key + ": expected a number, string or boolean");
    }
    out.push_back({key, std::move(v), {}});
  }
  return out;
}

nlohmann::json to_json(const DeviceModel& model) {
  const auto matrix = [](const Eigen::MatrixXd& m) {
    nlohmann::json rows = nlohmann::json::array();
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      nlohmann::json row = nlohmann::json::array();
      for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
      rows.push_back(std::move(row));
    }
    return rows;
  };
  const auto row = [](const Eigen::RowVectorXd& v) {
    nlohmann::json out = nlohmann::json::array();
    for (Eigen::Index j = 0; j < v.size(); ++j) out.push_back(v(j));
    return out;
  };
  const drivers::DeviceModel& info = model.info;
  return {{"motion", std::string(drivers::to_string(info.motion))},
          {"plant", !info.plant ? "rigid" : (info.plant->dynamics.a.rows() == 4 ? "two-mass" : "linear")},
          {"effective_mass", info.effective_mass},
          {"viscous_damping", info.viscous_damping},
          {"position_resolution", info.position_resolution},
          {"delay_periods", info.delay_periods},
          {"sensor", std::string(world::to_string(model.sensor))},
          {"period_s", model.period_s},
          {"source", info.source},
          {"description", info.description},
          {"summary", model.describe()},
          {"state_space",
           {{"a", matrix(model.plant.dynamics.a)},
            {"b", matrix(model.plant.dynamics.b)},
            {"motor_position", row(model.plant.motor_position)},
            {"body_position", row(model.plant.body_position)}}}};
}

}  // namespace hapticd::daemon
