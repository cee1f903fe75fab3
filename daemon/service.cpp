#include "daemon/service.hpp"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <sstream>

#include "daemon/config/host_checks.hpp"
#include "daemon/system/systemd_notify.hpp"
#include "daemon/version.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using namespace std::chrono_literals;

namespace {

world::ParameterSet to_parameter_set(const config::ParameterList& list) {
  world::ParameterSet out;
  for (const auto& p : list) out[p.key] = p.value;
  return out;
}

const config::Parameter* given(const config::SceneConfig& scene, std::string_view key) {
  for (const auto& p : scene.parameters) {
    if (p.key == key) return &p;
  }
  return nullptr;
}

/// The first given parameter (file order) without which -- i.e. at its
/// default -- the scene plans and, when the refusal was for instability, is
/// stable on the device: the one value the user has to change. Nothing when
/// no single parameter does it (the set as a whole is at fault).
const config::Parameter* culprit(const config::SceneConfig& scene, const world::ParameterSet& requested,
                                 const PlanRefusal& refusal, const DeviceModel& model) {
  for (const auto& p : scene.parameters) {
    if (!requested.contains(p.key)) continue;  // force: not a scene parameter
    world::ParameterSet without = requested;
    without.erase(p.key);
    auto outcome = world::plan_scene(scene.name, without, model.period_s, model.motion());
    const auto* plan = std::get_if<world::ScenePlan>(&outcome);
    if (plan != nullptr && (refusal.invalid || check_stability(*plan, model).stable)) return &p;
  }
  return nullptr;
}

/// A refused [scene] as a config error, at the position of the parameter at
/// fault: the one the planner names, else the culprit, else scene.name.
config::ConfigError scene_error(const config::SceneConfig& scene, const world::ParameterSet& requested,
                                const PlanRefusal& refusal, const DeviceModel& model) {
  const std::string text = refusal_text(refusal, force_in_config);
  if (const auto* named = given(scene, refusal.parameter)) {
    return {named->where, "scene." + named->key, text};
  }
  if (const auto* p = culprit(scene, requested, refusal, model)) {
    return {p->where, "scene." + p->key, "scene." + p->key + " = " + config::to_toml(p->value) + ": " + text};
  }
  return {scene.name_where, "scene", text};
}

std::size_t power_of_two_at_least(std::size_t n) {
  std::size_t p = 2;
  while (p < n) p <<= 1;
  return p;
}

std::string device_label(const drivers::DeviceInfo& info, const drivers::loopback::LoopbackDevice* loopback) {
  std::string s = info.driver + " (" + (info.motion == drivers::Motion::rotary ? "rotary" : "linear");
  if (loopback != nullptr) s += ", " + std::string(drivers::loopback::to_string(loopback->config().plant));
  return s + ")";
}

double us(rt::Nanos n) { return std::chrono::duration<double, std::micro>(n).count(); }

json histogram_json(const rt::HistogramSnapshot& h) {
  if (h.count == 0) return {{"count", 0}};
  return {{"count", h.count},
          {"p50_us", us(h.percentile(0.5))},
          {"p99_us", us(h.percentile(0.99))},
          {"p999_us", us(h.percentile(0.999))},
          {"max_us", static_cast<double>(h.max_ns) * 1e-3}};
}

std::vector<std::string> names_of(const std::vector<world::ChannelDescription>& channels) {
  std::vector<std::string> names;
  names.reserve(channels.size());
  for (const auto& c : channels) names.push_back(c.name);
  return names;
}

/// A member the method does not take is an error, not silently ignored.
void reject_unknown_keys(const char* method, const json& params,
                         std::initializer_list<const char*> accepted) {
  for (const auto& [key, value] : params.items()) {
    bool known = false;
    for (const char* a : accepted) known = known || key == a;
    if (known) continue;
    std::string list;
    for (const char* a : accepted) {
      if (!list.empty()) list += ", ";
      list += a;
    }
    throw RpcError(code::invalid_params,
                   std::string(method) + ": unknown member '" + key + "'; accepted: " + list);
  }
}

bool get_force(const json& params) {
  if (!params.contains("force")) return false;
  if (!params["force"].is_boolean()) throw RpcError(code::invalid_params, "force must be true or false");
  return params["force"].get<bool>();
}

}  // namespace

Service::Service(ServiceOptions options) : options_(std::move(options)) {
  const auto& cfg = options_.config;
  // NOLINTNEXTLINE(concurrency-mt-unsafe): start-up, no setenv
  config::check_host(cfg, std::getenv("STATE_DIRECTORY"));
  device_ = build_device(cfg);
  model_ = make_device_model(*device_.device, device_.loopback, cfg.loop.period_s);
  initial_requested_ = to_parameter_set(cfg.scene.parameters);
  // `force = true` in [scene] is the config's explicit override for showing
  // an instability on purpose (Freudenberg Fig. 8); it is not a scene parameter.
  bool force = false;
  if (const auto it = initial_requested_.find("force"); it != initial_requested_.end()) {
    const auto* flag = std::get_if<bool>(&it->second);
    if (flag == nullptr) {
      throw config::ConfigError(
          given(cfg.scene, "force")->where, "scene.force",
          "scene.force = " + config::to_toml(it->second) + " has the wrong type; accepted: true or false");
    }
    force = *flag;
    initial_requested_.erase(it);
  }
  auto outcome = plan_on_device(cfg.scene.name, initial_requested_, model_, force);
  if (const auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
    throw scene_error(cfg.scene, initial_requested_, *refusal, model_);
  }
  initial_ = std::move(std::get<PlannedScene>(outcome));
}

Service::~Service() { shutdown(); }

std::string Service::describe() const {
  const auto& cfg = options_.config;
  std::ostringstream out;
  out << "device: " << device_label(model_.info, device_.loopback) << ", " << model_.describe()
      << ", torque limit " << cfg.device.torque_limit
      << (model_.info.motion == drivers::Motion::rotary ? " N m" : " N") << "\nloop: period "
      << cfg.loop.period_s * 1e3 << " ms, clock " << config::to_string(cfg.loop.clock)
      << "\nscene: " << initial_.plan.scene;
  for (const auto& [k, v] : initial_.plan.parameters) out << " " << k << "=" << to_text(v);
  out << "\nstability: " << initial_.stability.summary;
  return out.str();
}

recorder::RecordingHeader Service::header_for(const CurrentScene& scene) const {
  recorder::RecordingHeader h;
  h.scene = scene.name;
  const bool rotary = model_.info.motion == drivers::Motion::rotary;
  const auto* description = world::find_scene(scene.name);
  for (const auto& [name, value] : scene.resolved) {
    std::string rendered = to_text(value);
    if (description != nullptr) {
      for (const auto& p : description->parameters) {
        if (p.name != name) continue;
        const std::string& unit = rotary && !p.rotary_unit.empty() ? p.rotary_unit : p.unit;
        if (!unit.empty() && std::holds_alternative<double>(value)) rendered += " " + unit;
      }
    }
    h.parameters.emplace_back(name, rendered);
  }
  for (const auto& c : scene.channels) h.channels.push_back({c.name, c.unit});
  h.rotary = rotary;
  h.period_s = options_.config.loop.period_s;
  h.clock = std::string(config::to_string(options_.config.loop.clock));
  h.device = device_label(model_.info, device_.loopback) + ", " + model_.describe();
  h.notes = scene.notes;
  h.notes.push_back("stability: " + scene.stability.summary);
  if (scene.forced) h.notes.push_back("UNSTABLE parameters loaded with force=true");
  return h;
}

CurrentScene Service::scene_from(const PlannedScene& planned, const world::ParameterSet& requested) {
  CurrentScene next;
  next.name = planned.plan.scene;
  next.requested = requested;
  next.resolved = planned.plan.parameters;
  next.channels = planned.plan.channels;
  next.stability = planned.stability;
  next.forced = planned.forced;
  next.notes = planned.plan.notes;
  return next;
}

std::uint64_t Service::publish(const PlannedScene& planned) {
  auto plan = std::make_unique<engine::LoopPlan>();
  plan->scene = planned.plan.scene_object;
  plan->torque_limit = options_.config.device.torque_limit;
  plan->unstable_forced = planned.forced;
  return engine_->publish(std::move(plan)).seq;
}

void Service::adopt(CurrentScene next) {
  std::lock_guard lock(scene_mutex_);
  previous_channels_ = names_of(scene_.channels);
  scene_ = std::move(next);
}

json Service::apply(const PlannedScene& planned, const world::ParameterSet& requested) {
  if (engine_->finished()) throw RpcError(code::busy, "the RT loop has stopped; nothing can take effect");
  const auto seq = publish(planned);
  const auto cycle = engine_->wait_applied(seq, 2000ms);
  if (!cycle) throw RpcError(code::busy, "the RT loop did not take the new scene within 2 s");
  CurrentScene next = scene_from(planned, requested);
  next.effective_cycle = *cycle;
  recorder_->set_scene(header_for(next), *cycle);
  json reply{{"scene", next.name},
             {"parameters", to_json(next.resolved, next.name)},
             {"units", parameter_units(next.name, model_.motion())},
             {"effective_cycle", *cycle},
             {"stability", to_json(next.stability)},
             {"forced", next.forced},
             {"notes", next.notes}};
  adopt(std::move(next));
  return reply;
}

drivers::loopback::LoopbackDevice& Service::loopback(const char* method) const {
  if (device_.loopback == nullptr) {
    throw RpcError(code::refused, std::string(method) + " needs the loopback device; this daemon drives " +
                                      model_.info.driver);
  }
  return *device_.loopback;
}

json Service::sample_json(const TelemetrySample& s, const std::vector<std::string>& wanted) const {
  std::vector<std::string> names;
  {
    std::lock_guard lock(scene_mutex_);
    names = s.cycle >= scene_.effective_cycle ? names_of(scene_.channels) : previous_channels_;
  }
  json all{{"cycle", s.cycle},         {"time_s", s.time_s},   {"position", s.position},
           {"command", s.command},     {"applied", s.applied}, {"latency_s", s.latency_s},
           {"compute_s", s.compute_s}, {"flags", s.flags}};
  for (std::size_t i = 0; i < names.size() && i < s.channel_count; ++i) all[names[i]] = s.channels[i];
  if (wanted.empty()) return all;
  json out{{"cycle", s.cycle}, {"time_s", s.time_s}};
  for (const auto& name : wanted) {
    if (!all.contains(name)) {
      std::string accepted;
      for (const auto& [k, v] : all.items()) accepted += (accepted.empty() ? "" : ", ") + k;
      throw RpcError(code::invalid_params, "unknown channel '" + name + "'; accepted: " + accepted);
    }
    out[name] = all[name];
  }
  return out;
}

json Service::status() const {
  const auto& cfg = options_.config;
  CurrentScene scene;
  {
    std::lock_guard lock(scene_mutex_);
    scene = scene_;
  }
  const engine::FaultReason fault = engine_->fault();
  json out{
      {"version", version},
      {"state", engine_->finished() ? "stopped" : (fault == engine::FaultReason::none ? "running" : "fault")},
      {"fault",
       fault == engine::FaultReason::none ? json(nullptr) : json(std::string(engine::to_string(fault)))},
      {"cycle", engine_->cycle()},
      {"time_s", static_cast<double>(engine_->cycle()) * cfg.loop.period_s},
      {"period_s", cfg.loop.period_s},
      {"clock", config::to_string(cfg.loop.clock)},
      {"torque_limit", cfg.device.torque_limit},
      {"device",
       {{"driver", model_.info.driver},
        {"motion", model_.info.motion == drivers::Motion::rotary ? "rotary" : "linear"},
        {"description", model_.describe()},
        {"effective_mass", model_.info.effective_mass},
        {"delay_samples", model_.info.inherent_delay_samples}}},
      {"scene",
       {{"name", scene.name},
        {"parameters", to_json(scene.resolved, scene.name)},
        {"units", parameter_units(scene.name, model_.motion())},
        {"stability", to_json(scene.stability)},
        {"forced", scene.forced},
        {"effective_cycle", scene.effective_cycle}}}};
  if (rt_report_ != nullptr) {
    out["realtime"] = {{"scheduler_set", rt_report_->scheduler_set},
                       {"priority", rt_report_->priority},
                       {"memory_locked", rt_report_->memory_locked},
                       {"dma_latency_held", rt_report_->dma_latency_held},
                       {"problems", rt_report_->problems}};
  }
  const auto rec = recorder_->status();
  out["recording"] = {{"active", rec.recording},
                      {"path", rec.path.string()},
                      {"samples", rec.samples_written},
                      {"dropped", rec.dropped_ring + rec.dropped_write},
                      {"disk_full", rec.disk_full},
                      {"resumed", rec.resumed},
                      {"error", rec.error}};
  {
    std::lock_guard lock(latest_mutex_);
    if (latest_) out["last"] = sample_json(*latest_, {});
  }
  return out;
}

json Service::stats() const {
  const auto s = engine_->stats();
  const auto c = engine_->counters();
  const auto rec = recorder_->status();
  json out{{"cycles", s.cycles},
           {"overruns", s.overruns},
           {"missed_periods", s.missed_periods},
           {"overrun_streak", s.overrun_streak},
           {"max_overrun_streak", s.max_overrun_streak},
           {"latency", histogram_json(s.latency)},
           {"compute", histogram_json(s.compute)},
           {"read_errors", c.read_errors},
           {"write_errors", c.write_errors},
           {"torque_limited", c.torque_limited},
           {"faults_latched", c.faults_latched},
           {"telemetry_dropped", c.telemetry_dropped},
           {"recorder",
            {{"samples_drained", rec.samples_drained},
             {"samples_written", rec.samples_written},
             {"dropped_ring_total", rec.dropped_ring_total},
             {"dropped_write", rec.dropped_write},
             {"error", rec.error}}},
           {"control", control::to_json(server_->stats())}};
  const auto dev = device_.device->status();
  out["device"] = {
      {"read_errors", dev.read_errors}, {"write_errors", dev.write_errors}, {"faults", dev.faults}};
  return out;
}

void Service::register_methods(control::ControlServer& server) {
  using control::Access;
  using control::PeerInfo;

  server.register_method(
      "status", [this](const json&, const PeerInfo&) { return status(); }, Access::read);
  server.register_method(
      "stats", [this](const json&, const PeerInfo&) { return stats(); }, Access::read);

  server.register_method(
      "scene.list",
      [this](const json&, const PeerInfo&) {
        json scenes = json::array();
        for (const auto& d : world::scene_catalog()) {
          json params = json::array();
          for (const auto& p : d.parameters) {
            json entry{{"name", p.name},
                       {"type", world::to_string(p.type)},
                       {"unit", unit_on(p, model_.motion())},
                       {"help", p.help}};
            std::visit([&](const auto& v) { entry["default"] = v; }, p.default_value);
            if (const auto* number = std::get_if<double>(&p.default_value);
                number != nullptr && p.type == world::ParameterType::integer) {
              entry["default"] = static_cast<std::int64_t>(std::llround(*number));
            }
            if (!p.accepted.empty()) entry["accepted"] = p.accepted;
            if (p.minimum) {
              entry["minimum"] = *p.minimum;
              if (p.minimum_exclusive) entry["minimum_exclusive"] = true;
            }
            if (p.maximum) entry["maximum"] = *p.maximum;
            params.push_back(entry);
          }
          scenes.push_back(
              {{"name", d.name}, {"reference", d.reference}, {"summary", d.summary}, {"parameters", params}});
        }
        std::lock_guard lock(scene_mutex_);
        return json{{"scenes", scenes}, {"current", scene_.name}};
      },
      Access::read);

  server.register_method(
      "scene.load",
      [this](const json& params, const PeerInfo&) {
        if (!params.contains("scene") || !params["scene"].is_string()) {
          throw RpcError(code::invalid_params, "scene.load needs \"scene\": one of " + world::scene_names());
        }
        world::ParameterSet requested;
        try {
          requested = parameters_from_json(params.value("params", json::object()));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        auto outcome =
            plan_on_device(params["scene"].get<std::string>(), requested, model_, get_force(params));
        if (auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
          throw RpcError(refusal->invalid ? code::invalid_params : code::refused,
                         refusal_text(*refusal, force_over_rpc), refusal->data);
        }
        return apply(std::get<PlannedScene>(outcome), requested);
      },
      Access::write);

  server.register_method(
      "param.get",
      [this](const json& params, const PeerInfo&) {
        CurrentScene scene;
        {
          std::lock_guard lock(scene_mutex_);
          scene = scene_;
        }
        json all = to_json(scene.resolved, scene.name);
        json out = json::object();
        if (params.contains("names")) {
          if (!params["names"].is_array())
            throw RpcError(code::invalid_params, "names must be a list of strings");
          for (const auto& n : params["names"]) {
            if (!n.is_string() || !all.contains(n.get<std::string>())) {
              std::string accepted;
              for (const auto& [k, v] : all.items()) accepted += (accepted.empty() ? "" : ", ") + k;
              throw RpcError(code::invalid_params, "scene " + scene.name + " has no parameter " + n.dump() +
                                                       "; accepted: " + accepted);
            }
            out[n.get<std::string>()] = all[n.get<std::string>()];
          }
        } else {
          out = all;
        }
        json units = parameter_units(scene.name, model_.motion());
        json shown_units = json::object();
        for (const auto& [name, value] : out.items()) {
          if (units.contains(name)) shown_units[name] = units[name];
        }
        return json{{"scene", scene.name}, {"parameters", out}, {"units", shown_units}};
      },
      Access::read);

  server.register_method(
      "param.set",
      [this](const json& params, const PeerInfo&) {
        world::ParameterSet changes;
        try {
          changes = parameters_from_json(params.value("params", json::object()));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        if (changes.empty())
          throw RpcError(code::invalid_params, "param.set needs \"params\": {name: value, ...}");
        CurrentScene scene;
        {
          std::lock_guard lock(scene_mutex_);
          scene = scene_;
        }
        world::ParameterSet requested = scene.requested;
        for (auto& [k, v] : changes) requested[k] = v;
        auto outcome = plan_on_device(scene.name, requested, model_, get_force(params));
        if (auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
          throw RpcError(refusal->invalid ? code::invalid_params : code::refused,
                         refusal_text(*refusal, force_over_rpc), refusal->data);
        }
        return apply(std::get<PlannedScene>(outcome), requested);
      },
      Access::write);

  server.register_method(
      "record.start",
      [this](const json& params, const PeerInfo&) {
        reject_unknown_keys("record.start", params, {"path"});
        const std::string name = params.value("path", std::string());
        CurrentScene scene;
        {
          std::lock_guard lock(scene_mutex_);
          scene = scene_;
        }
        try {
          const auto path = recorder_->start(name, header_for(scene));
          return json{{"path", path.string()}, {"cycle", engine_->cycle()}};
        } catch (const recorder::RecorderError& e) {
          throw RpcError(code::refused, e.what());
        }
      },
      Access::write);

  server.register_method(
      "record.stop",
      [this](const json&, const PeerInfo&) {
        recorder::RecorderStatus status;
        try {
          status = recorder_->stop();
        } catch (const recorder::RecorderError& e) {
          throw RpcError(code::refused, e.what());
        }
        return json{{"path", status.path.string()},
                    {"samples", status.samples_written},
                    {"samples_received", status.samples_received},
                    {"sections", status.sections},
                    {"dropped_ring", status.dropped_ring},
                    {"dropped_write", status.dropped_write},
                    {"cycle_gaps", status.cycle_gaps},
                    {"disk_full", status.disk_full},
                    {"resumed", status.resumed},
                    {"complete", status.complete},
                    {"error", status.error}};
      },
      Access::write);

  server.register_method(
      "hand.set",
      [this](const json& params, const PeerInfo&) {
        auto& device = loopback("hand.set");
        std::string text;
        if (params.contains("text")) {
          if (!params["text"].is_string()) throw RpcError(code::invalid_params, "text must be a string");
          text = params["text"].get<std::string>();
        } else {
          for (const auto& [k, v] : params.items()) {
            if (v.is_structured())
              throw RpcError(code::invalid_params, "hand.set: " + k + " must be a scalar");
            const std::string value = v.is_string() ? v.get<std::string>() : v.dump();
            // The script is key=value text: a space or '=' inside a value would
            // smuggle in another key.
            if (value.find_first_of(" \t\n=") != std::string::npos) {
              throw RpcError(code::invalid_params,
                             "hand.set: " + k + " = '" + value + "' may not contain spaces or '='");
            }
            text += k + "=" + value + " ";
          }
        }
        try {
          device.set_hand(text);
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        return json{{"hand", device.hand().to_text()}, {"cycle", engine_->cycle()}};
      },
      Access::write);

  server.register_method(
      "fault.inject",
      [this](const json& params, const PeerInfo&) {
        auto& device = loopback("fault.inject");
        const std::string kind = params.value("kind", std::string());
        const auto fault = drivers::loopback::parse_fault(kind);
        if (!fault) {
          throw RpcError(code::invalid_params, "fault.inject: unknown kind '" + kind + "'; accepted: " +
                                                   std::string(drivers::loopback::fault_names()));
        }
        reject_unknown_keys("fault.inject", params, {"kind", "amount"});
        std::int64_t amount = -1;
        if (*fault == drivers::loopback::Fault::encoder_jump && !params.contains("amount")) {
          throw RpcError(code::invalid_params,
                         "fault.inject: encoder-jump needs amount (the jump in encoder "
                         "counts, e.g. amount=1000 or amount=-1000)");
        }
        if (params.contains("amount")) {
          if (!params["amount"].is_number_integer()) {
            throw RpcError(code::invalid_params,
                           "amount must be a whole number (periods, or counts for encoder-jump)");
          }
          amount = params["amount"].get<std::int64_t>();
        }
        device.inject_fault(*fault, amount);
        return json{{"injected", kind}, {"amount", amount}, {"cycle", engine_->cycle()}};
      },
      Access::write);

  server.register_method(
      "fault.clear",
      [this](const json&, const PeerInfo&) {
        if (device_.loopback != nullptr) device_.loopback->clear_faults();
        const engine::FaultReason before = engine_->fault();
        engine_->clear_fault();
        return json{
            {"cleared", before == engine::FaultReason::none ? json(nullptr)
                                                            : json(std::string(engine::to_string(before)))},
            {"cycle", engine_->cycle()}};
      },
      Access::write);

  server.register_method(
      "estop",
      [this](const json&, const PeerInfo&) {
        engine_->estop();
        return json{{"fault", std::string(engine::to_string(engine_->fault()))}, {"cycle", engine_->cycle()}};
      },
      // Read access by design (docs/protocol.md): anyone who can connect may
      // stop the device; only writers can clear it (fault.clear). Served
      // before other clients' queued requests, whatever their load.
      Access::read, control::Precedence::first);

  server.set_stream_source([this](const std::vector<std::string>& channels) {
    std::optional<TelemetrySample> sample;
    {
      std::lock_guard lock(latest_mutex_);
      sample = latest_;
    }
    if (!sample) return json{{"cycle", 0}};
    return sample_json(*sample, channels);
  });
}

int Service::run() {
  const auto& cfg = options_.config;
  const bool virtual_clock = cfg.loop.clock == config::ClockKind::virtual_clock;
  if (virtual_clock) {
    clock_ = std::make_unique<rt::VirtualClock>();
  } else {
    clock_ = std::make_unique<rt::RealClock>();
  }

  engine::EngineOptions eo;
  eo.period = rt::Nanos(static_cast<std::int64_t>(std::llround(cfg.loop.period_s * 1e9)));
  // With the virtual clock the loop never sleeps: running it SCHED_FIFO would
  // starve the machine, so it stays a normal thread.
  eo.realtime.priority = virtual_clock ? 0 : cfg.loop.priority;
  if (cfg.loop.cpu >= 0) eo.realtime.cpus = {cfg.loop.cpu};
  eo.realtime.require_rt = cfg.loop.require_rt && !virtual_clock;
  eo.realtime.hold_dma_latency = !virtual_clock;
  eo.overrun_limit = virtual_clock ? 0 : cfg.loop.overrun_limit;
  if (cfg.loop.duration_s) {
    eo.duration = rt::Nanos(static_cast<std::int64_t>(std::llround(*cfg.loop.duration_s * 1e9)));
  }
  eo.telemetry_capacity = power_of_two_at_least(cfg.recorder.ring_capacity(cfg.loop.period_s));
  eo.wait_for_telemetry_space = virtual_clock;

  device_.device->start();
  engine_ = std::make_unique<engine::Engine>(eo, *device_.device, *clock_);

  const auto directory = config::resolve_recording_directory(
      cfg.recorder, std::getenv("STATE_DIRECTORY"));  // NOLINT(concurrency-mt-unsafe): start-up, no setenv
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  recorder::RecorderOptions ro;
  ro.directory = directory;
  ro.flush_interval_s = cfg.recorder.flush_interval_s;
  recorder_ = std::make_unique<recorder::Recorder>(
      [engine = engine_.get()](std::span<TelemetrySample> out) { return engine->drain(out); }, ro);
  recorder_->set_ring_drop_counter([engine = engine_.get()] { return engine->counters().telemetry_dropped; });
  recorder_->add_stream([this](std::span<const TelemetrySample> batch) {
    if (batch.empty()) return;
    std::lock_guard lock(latest_mutex_);
    latest_ = batch.back();
  });

  // The configured scene is published before the loop starts, so it is in
  // effect from cycle 1 (starting at equilibrium with the first measured
  // position), and a recording asked for at launch holds every cycle.
  const auto initial_seq = publish(initial_);
  CurrentScene first = scene_from(initial_, initial_requested_);
  if (!options_.record_name.empty()) {
    try {
      recorder_->start(options_.record_name, header_for(first));
    } catch (const recorder::RecorderError& e) {
      std::cerr << "hapticd: cannot record: " << e.what() << "\n";
      shutdown();
      return 1;
    }
  }

  const auto& report = engine_->start();
  rt_report_ = &report;
  if (report.fatal) {
    std::cerr << "hapticd: real-time scheduling is required (loop.require_rt / --require-rt) but:\n"
              << report.message() << "\n";
    shutdown();
    return 1;
  }
  if (!report.problems.empty()) std::cerr << "hapticd: running best-effort:\n" << report.message() << "\n";
  first.effective_cycle = engine_->wait_applied(initial_seq, 2000ms).value_or(1);
  adopt(std::move(first));

  control::ServerOptions so;
  so.socket_path = cfg.control.socket;
  so.group = cfg.control.group;
  so.max_clients = cfg.control.max_clients;
  so.max_message_bytes = cfg.control.max_message_bytes;
  so.idle_timeout = std::chrono::milliseconds(static_cast<std::int64_t>(cfg.control.idle_timeout_s * 1e3));
  server_ = std::make_unique<control::ControlServer>(so);
  register_methods(*server_);
  try {
    server_->start();
  } catch (const control::ServerError& e) {
    std::cerr << "hapticd: control socket: " << e.what() << "\n";
    shutdown();
    return 1;
  }

  std::cout << "hapticd " << version << ": " << device_label(model_.info, device_.loopback) << ", period "
            << cfg.loop.period_s * 1e3 << " ms, " << config::to_string(cfg.loop.clock) << " clock, scene "
            << initial_.plan.scene << "; control socket " << server_->socket_path() << std::endl;

  hapticd::daemon::system::SystemdNotifier notifier;
  notifier.ready();
  notifier.status("running scene " + initial_.plan.scene);
  const auto watchdog_every = notifier.watchdog_interval().value_or(std::chrono::microseconds(0)) / 2;
  auto next_ping = std::chrono::steady_clock::now();
  std::uint64_t last_cycle = 0;

  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  int exit_code = 0;
  for (;;) {
    timespec timeout{0, 50'000'000};
    const int sig = sigtimedwait(&signals, nullptr, &timeout);
    if (sig == SIGTERM || sig == SIGINT) {
      std::cout << "hapticd: " << (sig == SIGTERM ? "SIGTERM" : "SIGINT") << ": stopping" << std::endl;
      break;
    }
    if (engine_->finished()) {
      std::cout << "hapticd: loop finished after " << engine_->cycle() << " cycles" << std::endl;
      break;
    }
    // The watchdog is fed only while the RT loop makes progress.
    const auto now = std::chrono::steady_clock::now();
    if (watchdog_every.count() > 0 && now >= next_ping) {
      const std::uint64_t cycle = engine_->cycle();
      if (cycle != last_cycle) notifier.watchdog_ping();
      last_cycle = cycle;
      next_ping = now + watchdog_every;
    }
  }
  notifier.stopping();
  shutdown();
  return exit_code;
}

void Service::shutdown() {
  // Order matters: no new requests, then the loop stops and the device is
  // zeroed and disabled, then the recorder drains what the loop produced.
  if (server_) server_->stop();
  if (engine_) engine_->stop();
  if (device_.device) {
    device_.device->write(0.0);
    device_.device->stop();
  }
  if (recorder_) {
    if (recorder_->status().recording) {
      const auto s = recorder_->stop();
      std::cout << "hapticd: recording " << s.path.string() << ": " << s.samples_written << " samples, "
                << s.dropped_ring + s.dropped_write << " dropped"
                << (s.complete ? std::string() : "; incomplete (no trailer): " + s.error) << std::endl;
    }
    recorder_.reset();
  }
  server_.reset();
  engine_.reset();
}

}  // namespace hapticd::daemon
