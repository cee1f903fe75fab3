#include "daemon/service.hpp"

#include <chrono>
#include <cmath>

#include "daemon/methods/method_support.hpp"
#include "daemon/version.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;
using methods::names_of;

namespace {

double us(rt::Nanos n) { return std::chrono::duration<double, std::micro>(n).count(); }

json histogram_json(const rt::HistogramSnapshot& h) {
  if (h.count == 0) return {{"count", 0}};
  return {{"count", h.count},
          {"p50_us", us(h.percentile(0.5))},
          {"p99_us", us(h.percentile(0.99))},
          {"p999_us", us(h.percentile(0.999))},
          {"max_us", static_cast<double>(h.max_ns) * 1e-3}};
}

}  // namespace

// Status, statistics and the telemetry stream (docs/protocol.md).

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

// The latched fault in words with its figures (an encoder jump's step, in
// SI and counts, the limit, the interval), or null when it has none.
json Service::fault_detail() const {
  const auto jump = engine_->position_jump();
  if (!jump) return nullptr;
  const auto& rule = position_rule_;
  json out{{"text", engine::describe(*jump, rule)},
           {"unit", rule.rotary ? "rad" : "m"},
           {"step", jump->step},
           {"limit", jump->limit},
           {"max_velocity", rule.max_velocity},
           {"interval_s", jump->interval_s}};
  if (jump->axis >= 0 && static_cast<std::size_t>(jump->axis) < model_.axis_names.size())
    out["axis"] = model_.axis_names[static_cast<std::size_t>(jump->axis)];
  if (rule.resolution > 0.0) {
    out["resolution"] = rule.resolution;
    if (const double counts = jump->step / rule.resolution; std::abs(counts) < 9e18)
      out["step_counts"] = std::llround(counts);
  }
  return out;
}

json Service::status() const {
  const auto& cfg = options_.config;
  const CurrentScene scene = current_scene();
  const engine::FaultReason fault = engine_->fault();
  const auto device = device_.device->status();
  json out{
      {"version", version},
      {"state", engine_->finished() ? "stopped" : (fault == engine::FaultReason::none ? "running" : "fault")},
      {"fault",
       fault == engine::FaultReason::none ? json(nullptr) : json(std::string(engine::to_string(fault)))},
      {"fault_detail", fault_detail()},
      {"cycle", engine_->cycle()},
      {"time_s", static_cast<double>(engine_->cycle()) * cfg.loop.period_s},
      {"period_s", cfg.loop.period_s},
      {"clock", config::to_string(cfg.loop.clock)},
      {"torque_limit", cfg.device.torque_limit},
      {"device",
       {{"driver", cfg.device.driver},
        {"motion", std::string(drivers::to_string(model_.info.motion))},
        {"description", model_.describe()},
        {"effective_mass", model_.info.effective_mass},
        {"delay_samples", model_.info.delay_periods},
        {"max_velocity", position_rule_.max_velocity},
        {"position_step_limit", position_rule_.step_limit(position_rule_.period_s)},
        {"model_source", model_.info.source},
        {"state", std::string(drivers::to_string(device.state))},
        {"fault_reason", device.fault_reason.empty() ? json(nullptr) : json(device.fault_reason)}}},
      {"calibration", calibration_json()},
      {"scene",
       {{"name", scene.name},
        {"parameters", to_json(scene.resolved, scene.name)},
        {"units", parameter_units(scene.name, model_.motion())},
        {"stability", to_json(scene.stability)},
        {"forced", scene.forced},
        {"effective_cycle", scene.effective_cycle}}}};
  if (!model_.axis_names.empty()) {
    // Several axes: each one's name, mass and damping (one axis: nothing new).
    json axes = json::array();
    for (std::size_t i = 0; i < model_.axis_names.size(); ++i)
      axes.push_back({{"name", model_.axis_names[i]},
                      {"mass", model_.info.axes[i].mass},
                      {"damping", model_.info.axes[i].damping},
                      {"torque_limit", cfg.device.axis_limit(i)}});
    out["device"]["axes"] = axes;
    out["device"]["kinematics"] = cfg.device.kinematics;
  }
  // [gravity] and [workspace], only when configured (one axis: [gravity] alone).
  for (const auto& [key, value] : overlay_.status.items()) out[key] = value;
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
  json out{{"since_cycle", engine_->stats_since_cycle()},
           {"cycles", s.cycles},
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
           {"position_jumps", c.position_jumps},
           {"telemetry_dropped", c.telemetry_dropped},
           {"recorder",
            {{"samples_drained", rec.samples_drained},
             {"samples_written", rec.samples_written},
             {"dropped_ring_total", rec.dropped_ring_total},
             {"dropped_write", rec.dropped_write},
             {"error", rec.error}}},
           {"control", control::to_json(server_->stats())},
           {"telemetry", telemetry_counters_json()}};
  const auto dev = device_.device->status();
  out["device"] = {
      {"read_errors", dev.read_errors}, {"write_errors", dev.write_errors}, {"faults", dev.faults}};
  for (const auto& counter : dev.counters) out["device"][counter.name] = counter.value;
  return out;
}

void Service::register_status_methods(control::ControlServer& server) {
  server.register_method(
      "status", [this](const json&, const PeerInfo&) { return status(); }, Access::read);
  server.register_method(
      "stats", [this](const json&, const PeerInfo&) { return stats(); }, Access::read);
  // Starts the loop's timing statistics afresh (one measurement slice of
  // bench/latency.sh); the error, drop and control-plane counters are totals
  // since start and stay. Write access: it erases what others may be reading.
  server.register_method(
      "stats.reset",
      [this](const json&, const PeerInfo&) {
        const auto since = engine_->reset_stats(std::chrono::milliseconds(2000));
        if (!since) throw RpcError(code::busy, "the RT loop did not reset its statistics within 2 s");
        return json{{"since_cycle", *since}};
      },
      Access::write);

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

}  // namespace hapticd::daemon
