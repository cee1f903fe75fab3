#include "daemon/service.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <thread>

#include "daemon/config/host_checks.hpp"
#include "daemon/device_model.hpp"
#include "daemon/methods/method_support.hpp"
#include "daemon/system/systemd_notify.hpp"
#include "daemon/system/thread_placement.hpp"
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

rt::Nanos nanos(double seconds) { return rt::Nanos(static_cast<std::int64_t>(std::llround(seconds * 1e9))); }

/// [device] max_velocity, else its default from the device (docs/config.md).
engine::PositionStepRule position_rule_for(const config::DaemonConfig& cfg,
                                           const drivers::DeviceModel& model) {
  engine::PositionStepRule rule;
  rule.rotary = model.motion == drivers::Motion::rotary;
  rule.resolution = model.position_resolution > 0.0 ? model.position_resolution : 0.0;
  rule.period_s = cfg.loop.period_s;
  rule.max_velocity = cfg.device.max_velocity.value_or(
      engine::default_max_velocity(rule.rotary, model.effective_mass, cfg.device.torque_limit));
  return rule;
}

/// The axes' names of a device with several ([device] axis_names, else x,
/// y, z, a, b, c); ConfigError when the names do not fit the device.
std::vector<std::string> axis_names_for(const config::DeviceConfig& device, int axes, bool linkage) {
  static const std::vector<std::string> defaults{"x", "y", "z", "a", "b", "c"};
  // A linkage's axes are its motor joints, not the task axes x and y.
  static const std::vector<std::string> joints{"q1", "q2"};
  if (device.axis_names.empty() && linkage && axes == 2) return joints;
  if (device.axis_names.empty()) return {defaults.begin(), defaults.begin() + axes};
  if (static_cast<int>(device.axis_names.size()) != axes) {
    throw config::ConfigError(device.axis_names_where, "device.axis_names",
                              "device.axis_names names " + std::to_string(device.axis_names.size()) +
                                  " axes; the device (" + device.driver + ") has " + std::to_string(axes) +
                                  "; accepted: " + std::to_string(axes) + " names");
  }
  return device.axis_names;
}

/// The channels a device with several axes adds before the scene's, in the
/// engine's order (daemon/engine/task_axes.hpp): every position, every task
/// force, every joint output; a linkage's task forces are along x and y (N)
/// and the handle's position follows (m).
std::vector<world::ChannelDescription> axis_channels(const std::vector<std::string>& names, bool rotary,
                                                     bool linkage) {
  static const std::vector<std::string> task{"x", "y"};
  const auto& forces = linkage ? task : names;
  std::vector<world::ChannelDescription> out;
  out.reserve(3 * names.size() + 2);
  for (const auto& n : names) out.push_back({"position_" + n, rotary ? "rad" : "m"});
  for (const auto& n : forces) out.push_back({"force_" + n, rotary && !linkage ? "N m" : "N"});
  for (const auto& n : names) out.push_back({"output_" + n, rotary ? "N m" : "N"});
  if (linkage) {
    for (const auto& n : task) out.push_back({"handle_" + n, "m"});
  }
  return out;
}

}  // namespace

Service::Service(ServiceOptions options)
    : options_(std::move(options)), stop_(options_.stop != nullptr ? *options_.stop : never_) {
  const auto& cfg = options_.config;
  // NOLINTNEXTLINE(concurrency-mt-unsafe): start-up, no setenv
  config::check_host(cfg, std::getenv("STATE_DIRECTORY"));
  device_ = build_device(cfg);
  try {
    device_.device->configure(drivers::LoopContext{cfg.loop.period_s, stop_.token()});
  } catch (const drivers::DeviceError& e) {
    throw device_config_error(cfg.device, e);
  } catch (const drivers::StopRequested&) {
    device_.device->disable();
    device_.device->close();
    throw;
  }
  model_ = make_device_model(*device_.device, cfg.loop.period_s);
  if (!cfg.device.model.empty()) {
    // An identified model named by the config replaces the driver's for the gate.
    const auto keys = config::load_model_file(cfg.device.model, cfg.device.model_where);
    model_ = make_device_model(
        model_from_keys(keys, model_.info, cfg.loop.period_s, "identified: " + cfg.device.model,
                        config::SourcePosition{cfg.device.model, 0, 0}),
        cfg.loop.period_s);
  }
  resolve_axes();
  overlay_ = make_task_overlay(cfg, model_);
  position_rule_ = position_rule_for(cfg, model_.info);
  // Whose origin a stored one must be, and what the state directory holds.
  const drivers::DeviceModel device_model = device_.device->model();
  origin_identity_ = {cfg.device.driver, device_.device->identity(),
                      std::string(config::to_string(cfg.device.encoder)),
                      std::string(drivers::to_string(device_model.motion)),
                      device_model.position_resolution > 0.0 ? device_model.position_resolution : 0.0};
  if (device_.device->axes() == 1 && cfg.device.origin_keeping() == config::OriginKeeping::persist) {
    const char* state_directory = std::getenv("STATE_DIRECTORY");  // NOLINT(concurrency-mt-unsafe): no setenv
    stored_origin_ =
        find_stored_origin(config::resolve_origin_file(cfg.device, state_directory), origin_identity_);
  }
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
  check_telemetry_config();
}

Service::~Service() { shutdown(); }

namespace {
/// [device] axis_torque_limit: one limit per axis of a device with several.
void check_axis_torque_limit(const config::DeviceConfig& device, int axes) {
  const auto given = static_cast<int>(device.axis_torque_limit.size());
  if (given == 0 || given == axes) return;
  throw config::ConfigError(device.axis_torque_limit_where, "device.axis_torque_limit",
                            axes == 1
                                ? "device.axis_torque_limit is for a device with several axes; this one (" +
                                      device.driver + ") has one; accepted: torque_limit alone"
                                : "device.axis_torque_limit gives " + std::to_string(given) +
                                      " limits for the " + std::to_string(axes) + " axes of " +
                                      device.driver + "; accepted: one per axis, in order");
}
}  // namespace

void Service::resolve_axes() {
  const int axes = device_.device->axes();
  check_axis_torque_limit(options_.config.device, axes);
  if (axes == 1) return;
  if (model_.info.axis_count() != axes) {
    throw drivers::DeviceError(options_.config.device.driver + ": the device has " + std::to_string(axes) +
                               " axes but its model describes " + std::to_string(model_.info.axis_count()) +
                               "; each axis needs its mass and damping for the stability gate");
  }
  const auto& kinematics = options_.config.device.kinematics;
  const bool linkage = model_.info.pantograph.has_value();
  if (linkage != (kinematics == "pantograph")) {
    throw drivers::DeviceError(
        options_.config.device.driver + (linkage ? " simulates a pantograph" : " provides no linkage") +
        " and device.kinematics is \"" + kinematics +
        "\"; accepted: kinematics = \"pantograph\" exactly for a " +
        "device that reports its pantograph linkage (the loopback with linkage = \"pantograph\")");
  }
  model_.axis_names = axis_names_for(options_.config.device, axes, linkage);
  // The origin is one number for one axis (docs/config.md, "Calibration"):
  // a stage's positions are its own; no origin is taken, kept or required.
  const auto& device = options_.config.device;
  const bool persist = device.origin == config::OriginKeeping::persist;
  if (device.require_calibration || persist) {
    const std::string setting = persist ? "device.origin = \"persist\"" : "device.require_calibration = true";
    throw config::ConfigError(
        persist ? device.origin_where : config::SourcePosition{},
        persist ? "device.origin" : "device.require_calibration",
        setting + " is for a device with one axis; this one (" + device.driver + ") has " +
            std::to_string(axes) +
            ", whose positions are the stage's own; accepted: " + (persist ? "\"session\"" : "false"));
  }
}

std::string Service::device_label() const {
  return options_.config.device.driver + " (" + model_.info.description + ")";
}

std::string Service::describe() const {
  const auto& cfg = options_.config;
  std::ostringstream out;
  const std::string unit = model_.info.motion == drivers::Motion::rotary ? " N m" : " N";
  out << "device: " << device_label() << ", " << model_.describe() << ", torque limit "
      << cfg.device.torque_limit << unit;
  for (std::size_t i = 0; i < cfg.device.axis_torque_limit.size() && i < model_.axis_names.size(); ++i)
    out << (i == 0 ? " (" : ", ") << model_.axis_names[i] << " " << cfg.device.axis_limit(i) << unit
        << (i + 1 == cfg.device.axis_torque_limit.size() ? ")" : "");
  out << "\nloop: period " << cfg.loop.period_s * 1e3 << " ms, clock " << config::to_string(cfg.loop.clock)
      << "\nplausibility: " << engine::describe_rule(position_rule_, cfg.device.max_velocity.has_value())
      << "\nscene: " << initial_.plan.scene;
  for (const auto& [k, v] : initial_.plan.parameters) out << " " << k << "=" << to_text(v);
  out << "\nstability: " << initial_.stability.summary;
  const Calibration stored = initial_calibration(std::nullopt, stored_origin_);
  const bool one_axis = model_.axis_names.empty();
  out << "\ncalibration: encoder " << config::to_string(cfg.device.encoder) << ", origin "
      << (one_axis ? config::to_string(cfg.device.origin_keeping())
                   : "none (several axes: the stage's own positions)");
  if (one_axis && cfg.device.origin_keeping() == config::OriginKeeping::persist) {
    out << " (" << stored_origin_.file.string() << "): "
        << (stored.kind == CalibrationKind::restored
                ? summary(stored, model_.info.motion == drivers::Motion::rotary, cfg.device.encoder)
            : stored.note.empty() ? "nothing stored yet"
                                  : stored.note);
  }
  if (cfg.device.require_calibration) out << "; required before any scene renders";
  if (!model_.axis_names.empty()) {
    const bool rotary = model_.info.motion == drivers::Motion::rotary;
    out << "\naxes: " << options_.config.device.kinematics;
    for (std::size_t i = 0; i < model_.axis_names.size(); ++i)
      out << (i == 0 ? " " : ", ") << model_.axis_names[i] << " (" << model_.info.axes[i].mass
          << (rotary ? " kg m^2, " : " kg, ") << model_.info.axes[i].damping
          << (rotary ? " N m s/rad)" : " N s/m)");
    if (const auto& p = model_.info.pantograph) {
      out << "; links " << p->geometry.a1 << ", " << p->geometry.a2 << ", " << p->geometry.a3 << ", "
          << p->geometry.a4 << ", " << p->geometry.a5 << " m; workspace x " << p->x_min << " to " << p->x_max
          << " m, y " << p->y_min << " to " << p->y_max << " m";
    }
  }
  for (const auto& note : overlay_.notes) out << "\n" << note;  // [gravity], [workspace]
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
  h.device = device_label() + ", " + model_.describe();
  h.notes = scene.notes;
  if (!model_.axis_names.empty()) {
    h.notes.push_back("axes: " + std::to_string(model_.axis_names.size()) + ", " +
                      options_.config.device.kinematics +
                      " kinematics: each axis' position, task force (before the limit) and output (sent)");
  }
  h.notes.insert(h.notes.end(), overlay_.notes.begin(), overlay_.notes.end());
  h.notes.push_back("stability: " + scene.stability.summary);
  if (scene.forced) h.notes.push_back("UNSTABLE parameters loaded with force=true");
  // A recording says the origin its positions are measured from (none when
  // the device is not calibrated and need not be: as before calibration existed).
  const Calibration c = calibration();
  const auto& device = options_.config.device;
  if (c.kind != CalibrationKind::none) {
    h.notes.push_back("calibration: " + summary(c, rotary, device.encoder) +
                      "; positions are the device's minus the origin");
  } else if (device.require_calibration) {
    h.notes.push_back(
        "calibration: not calibrated; output held at zero (flag 128) until `hapticctl device zero`");
  }
  h.uncalibrated_flag = device.require_calibration;
  return h;
}

CurrentScene Service::scene_from(const PlannedScene& planned, const world::ParameterSet& requested) const {
  CurrentScene next;
  next.name = planned.plan.scene;
  next.requested = requested;
  next.resolved = planned.plan.parameters;
  next.channels = planned.plan.channels;
  if (!model_.axis_names.empty()) {
    auto axes = axis_channels(model_.axis_names, model_.info.motion == drivers::Motion::rotary,
                              model_.info.pantograph.has_value());
    const auto overlay = overlay_.channels(model_.axis_names, model_.info.motion == drivers::Motion::rotary);
    axes.insert(axes.end(), overlay.begin(), overlay.end());
    next.channels.insert(next.channels.begin(), axes.begin(), axes.end());
  } else {
    // One axis: [gravity]'s feedforward before the scene's channels, as the engine writes them.
    const auto overlay = overlay_.channels({}, false);
    next.channels.insert(next.channels.begin(), overlay.begin(), overlay.end());
  }
  next.stability = planned.stability;
  next.forced = planned.forced;
  next.notes = planned.plan.notes;
  return next;
}

std::uint64_t Service::publish(const PlannedScene& planned) {
  auto plan = std::make_unique<engine::LoopPlan>();
  plan->scene = planned.plan.scene_object;
  plan->task_scene = planned.plan.task_object;
  plan->torque_limit = options_.config.device.torque_limit;
  if (!options_.config.device.axis_torque_limit.empty()) {
    const auto n = static_cast<Eigen::Index>(options_.config.device.axis_torque_limit.size());
    plan->axis_torque_limits.resize(n);
    for (Eigen::Index i = 0; i < n; ++i)
      plan->axis_torque_limits(i) = options_.config.device.axis_limit(static_cast<std::size_t>(i));
  }
  plan->unstable_forced = planned.forced;
  return engine_->publish(std::move(plan)).seq;
}

void Service::adopt(CurrentScene next) {
  if (telemetry_) telemetry_->set_scene(methods::names_of(next.channels), next.effective_cycle);
  std::lock_guard lock(scene_mutex_);
  previous_channels_ = methods::names_of(scene_.channels);
  scene_ = std::move(next);
}

CurrentScene Service::current_scene() const {
  std::lock_guard lock(scene_mutex_);
  return scene_;
}

json Service::plan_and_apply(const std::string& scene, const world::ParameterSet& requested, bool force) {
  auto outcome = plan_on_device(scene, requested, model_, force);
  if (auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
    throw RpcError(refusal->invalid ? code::invalid_params : code::refused,
                   refusal_text(*refusal, force_over_rpc), refusal->data);
  }
  return apply(std::get<PlannedScene>(outcome), requested);
}

json Service::apply(const PlannedScene& planned, const world::ParameterSet& requested) {
  if (engine_->finished()) throw RpcError(code::busy, "the RT loop has stopped; nothing can take effect");
  telemetry_->hold_for_scene();  // until adopt() says from which cycle the new channel names hold
  recorder_->hold_for_scene();   // until set_scene() below: no new-scene sample under the old header
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
  if (output_held_uncalibrated()) {
    reply["notes"].push_back(
        "the output stays zero until the device is calibrated ([device] require_calibration): hapticctl "
        "device zero");
  }
  adopt(std::move(next));
  return reply;
}

void Service::register_methods(control::ControlServer& server) {
  register_status_methods(server);
  register_scene_methods(server);
  register_record_methods(server);
  register_fault_methods(server);
  register_device_methods(server);
  register_model_methods(server);
  register_telemetry_methods(server);
  register_calibration_methods(server);
}

// ---- run(), step by step ----------------------------------------------------

void Service::start_engine() {
  const auto& cfg = options_.config;
  const bool virtual_clock = cfg.loop.clock == config::ClockKind::virtual_clock;
  if (virtual_clock) {
    clock_ = std::make_unique<rt::VirtualClock>();
  } else {
    clock_ = std::make_unique<rt::RealClock>();
  }
  engine::EngineOptions eo;
  eo.period = nanos(cfg.loop.period_s);
  // With the virtual clock the loop never sleeps: running it SCHED_FIFO would
  // starve the machine, so it stays a normal thread.
  eo.realtime.priority = virtual_clock ? 0 : cfg.loop.priority;
  if (cfg.loop.cpu >= 0) eo.realtime.cpus = {cfg.loop.cpu};
  eo.realtime.require_rt = cfg.loop.require_rt && !virtual_clock;
  eo.realtime.hold_dma_latency = !virtual_clock;
  eo.overrun_limit = virtual_clock ? 0 : cfg.loop.overrun_limit;
  eo.position_rule = position_rule_;
  eo.require_calibration = cfg.device.require_calibration;
  eo.gravity = overlay_.gravity;
  eo.workspace = overlay_.workspace;
  if (cfg.loop.duration_s) eo.duration = nanos(*cfg.loop.duration_s);
  eo.telemetry_capacity = power_of_two_at_least(cfg.recorder.ring_capacity(cfg.loop.period_s));
  eo.wait_for_telemetry_space = virtual_clock;
  if (const auto& linkage = model_.info.pantograph)
    eo.kinematics = world::PantographKinematics(linkage->geometry);
  engine_ = std::make_unique<engine::Engine>(eo, *device_.device, *clock_);
}

void Service::start_recorder() {
  const auto& cfg = options_.config;
  const auto directory = config::resolve_recording_directory(
      cfg.recorder, std::getenv("STATE_DIRECTORY"));  // NOLINT(concurrency-mt-unsafe): start-up, no setenv
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  recorder::RecorderOptions ro;
  ro.directory = directory;
  ro.flush_interval_s = cfg.recorder.flush_interval_s;
  if (cfg.recorder.cpu >= 0) ro.cpus = {cfg.recorder.cpu};
  recorder_ = std::make_unique<recorder::Recorder>(
      [engine = engine_.get()](std::span<TelemetrySample> out) { return engine->drain(out); }, ro);
  recorder_->set_ring_drop_counter([engine = engine_.get()] { return engine->counters().telemetry_dropped; });
  recorder_->add_stream([this](std::span<const TelemetrySample> batch) {
    if (batch.empty()) return;
    std::lock_guard lock(latest_mutex_);
    latest_ = batch.back();
  });
}

bool Service::start_loop(std::uint64_t initial_seq, CurrentScene first) {
  const auto& report = engine_->start();
  rt_report_ = &report;
  if (report.fatal) {
    std::cerr << "hapticd: real-time scheduling is required (loop.require_rt / --require-rt) but:\n"
              << report.message() << "\n";
    return false;
  }
  if (!report.problems.empty()) std::cerr << "hapticd: running best-effort:\n" << report.message() << "\n";
  first.effective_cycle = engine_->wait_applied(initial_seq, 2000ms).value_or(1);
  adopt(std::move(first));
  return true;
}

bool Service::start_control() {
  const auto& cfg = options_.config;
  control::ServerOptions so;
  so.socket_path = cfg.control.socket;
  so.group = cfg.control.group;
  so.max_clients = cfg.control.max_clients;
  so.max_message_bytes = cfg.control.max_message_bytes;
  so.idle_timeout = std::chrono::milliseconds(static_cast<std::int64_t>(cfg.control.idle_timeout_s * 1e3));
  if (cfg.control.cpu >= 0) so.cpus = {cfg.control.cpu};
  server_ = std::make_unique<control::ControlServer>(so);
  register_methods(*server_);
  try {
    server_->start();
  } catch (const control::ServerError& e) {
    std::cerr << "hapticd: control socket: " << e.what() << "\n";
    return false;
  }
  return true;
}

int Service::run() {
  // On this (non-preemptible, PREEMPT_NONE) kernel a thread inside a long
  // system call -- the recorder's write(), the control thread's sends --
  // delays the RT thread's wake-up on the same CPU until it returns: keep
  // every other thread off the loop's CPU. They inherit this thread's mask;
  // [control] cpu and [recorder] cpu still place them explicitly, and the
  // loop pins itself. (bench/latency.sh measured the difference: README.)
  if (options_.config.loop.cpu >= 0) {
    if (const auto problem = system::keep_off_cpu(options_.config.loop.cpu); !problem.empty())
      std::cerr << "hapticd: " << problem << "; other threads may share the loop's CPU\n";
  }
  start_engine();
  try {
    device_.device->enable();
  } catch (const drivers::DeviceError& e) {
    // A refusal with a key to blame (a homing key, rated_torque) is said at its file:line:column.
    std::cerr << "hapticd: device: "
              << (e.key().empty() ? e.what() : device_config_error(options_.config.device, e).what()) << "\n";
    shutdown();
    return 1;
  } catch (const drivers::StopRequested& e) {
    std::cout << "hapticd: stopped by " << stop_.why() << " during enable (" << e.what() << ")" << std::endl;
    shutdown();
    return 0;
  }
  start_calibration();
  start_recorder();
  if (!start_telemetry()) {
    shutdown();
    return 1;
  }
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
  if (!start_loop(initial_seq, std::move(first)) || !start_control()) {
    shutdown();
    return 1;
  }
  const auto& cfg = options_.config;
  std::cout << "hapticd " << version << ": " << device_label() << ", period " << cfg.loop.period_s * 1e3
            << " ms, " << config::to_string(cfg.loop.clock) << " clock, scene " << initial_.plan.scene
            << "; control socket " << server_->socket_path() << std::endl;
  const int exit_code = supervise();
  shutdown();
  return exit_code;
}

int Service::supervise() {
  system::SystemdNotifier notifier;
  notifier.ready();
  notifier.status("running scene " + initial_.plan.scene);
  const auto watchdog_every = notifier.watchdog_interval().value_or(std::chrono::microseconds(0)) / 2;
  auto next_ping = std::chrono::steady_clock::now();
  std::uint64_t last_cycle = 0;

  for (;;) {
    if (stop_.requested()) {
      std::cout << "hapticd: " << stop_.why() << ": stopping" << std::endl;
      break;
    }
    std::this_thread::sleep_for(50ms);
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
  return 0;
}

void Service::shutdown() {
  // Order matters: no new requests, then the loop stops, then the device is
  // zeroed, disabled and closed, then the recorder drains what the loop produced.
  if (server_) server_->stop();
  if (engine_ && !engine_->finished()) {
    engine_->stop();
    // What a recording from launch must hold, row for row (tests/e2e).
    if (engine_->cycle() > 0)
      std::cout << "hapticd: loop stopped after " << engine_->cycle() << " cycles" << std::endl;
  }
  if (engine_) engine_->stop();
  if (device_.device) {
    device_.device->disable();
    device_.device->close();
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
  stop_telemetry();  // after the recorder: it sends what the last drain gave it
  server_.reset();
  engine_.reset();
}

}  // namespace hapticd::daemon
