#include "analysis/passivity_study.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

#include "analysis/non_finite.hpp"
#include "analysis/stability_gate.hpp"
#include "analysis/wall_stability.hpp"
#include "world/passivity_scene.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::nan;

world::AnyScene wall_scene(const PassivityStudyOptions& o, double stiffness, const char* passivity) {
  const world::ParameterSet p{{"stiffness", stiffness},
                              {"damping", o.damping},
                              {"delay", static_cast<double>(o.delay)},
                              {"passivity", std::string(passivity)}};
  auto outcome = world::plan_scene("wall", p, o.period_s, world::Motion::linear);
  if (auto* error = std::get_if<world::SceneError>(&outcome)) throw std::invalid_argument(error->message);
  return std::get<world::ScenePlan>(outcome).scene_object;
}

bool finite(double x) { return std::isfinite(x); }

std::string number_text(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", x);
  return buffer;
}

}  // namespace

const char* to_string(ContactVerdict verdict) noexcept {
  switch (verdict) {
    case ContactVerdict::bounded:
      return "bounded";
    case ContactVerdict::growing:
      return "growing";
    case ContactVerdict::diverged:
      return "diverged";
  }
  return "diverged";
}

PassivityRunSummary summarize_contact(ContactRun run, double stiffness, const ContactHand& hand,
                                      double window_start_s) {
  PassivityRunSummary s;
  const double push_force = stiffness * hand.stiffness * hand.reference / (stiffness + hand.stiffness);
  double sum_squares = 0.0, peak = 0.0, sum_alpha = 0.0, peak_alpha = 0.0;
  std::size_t count = 0;
  bool all_finite = true;
  for (const ContactSample& x : run.trace) {
    if (!x.pushing || x.time_s < window_start_s) continue;
    const double ideal = x.position > 0.0 ? -stiffness * x.position : 0.0;
    const double error = x.force - ideal;
    all_finite = all_finite && finite(error) && finite(x.passivity_damping);
    sum_squares += error * error;
    peak = std::max(peak, std::abs(error));
    sum_alpha += x.passivity_damping;
    peak_alpha = std::max(peak_alpha, x.passivity_damping);
    ++count;
  }
  s.window_samples = static_cast<double>(count);
  if (count > 0) {
    const double n = static_cast<double>(count);
    s.rms_error = std::sqrt(sum_squares / n);
    s.peak_error = peak;
    s.mean_damping = sum_alpha / n;
    s.peak_damping = peak_alpha;
  } else {
    s.rms_error = s.peak_error = s.mean_damping = s.peak_damping = nan;
  }
  s.rms_relative = s.rms_error / push_force;
  s.peak_relative = s.peak_error / push_force;
  s.peak_force = run.peak_force;
  s.late_amplitude = run.diverged ? nan : run.late.amplitude;
  s.late_ratio = s.late_amplitude / run.static_penetration;
  // A verdict of bounded only from finite numbers over the whole window.
  const bool measured = !run.diverged && all_finite && count > 0 && finite(s.rms_error) &&
                        finite(s.late_ratio) && finite(run.early.amplitude) && finite(run.peak_force);
  if (!measured) {
    s.verdict = ContactVerdict::diverged;
  } else if (run.late.amplitude > 1.05 * run.early.amplitude + 1e-6) {
    s.verdict = ContactVerdict::growing;
  } else {
    s.verdict = ContactVerdict::bounded;
  }
  s.run = std::move(run);
  return s;
}

PassivityStudy passivity_study(const PassivityStudyOptions& options) {
  if (!(options.mass > 0.0) || !std::isfinite(options.mass))
    throw std::invalid_argument("mass must be a finite number > 0 (kg)");
  if (!(options.period_s > 0.0) || !std::isfinite(options.period_s))
    throw std::invalid_argument("period must be a finite duration > 0");
  if (!(options.window_start_s >= 0.0 && options.window_start_s < options.hand.release_s))
    throw std::invalid_argument("the measured window must start before the hand's release");
  PassivityStudy study;
  study.options = options;
  const double beta = normalized_damping(options.damping, options.mass, options.period_s);
  study.fixed_gain_limit = physical_stiffness(alpha_max(beta, options.delay), options.mass, options.period_s);
  if (!(study.fixed_gain_limit > 0.0) || !std::isfinite(study.fixed_gain_limit))
    throw std::invalid_argument(
        "no stiffness > 0 is stable with fixed gains at B = " + number_text(options.damping) +
        " N s/m, d = " + std::to_string(options.delay) + ": there is no limit to scale");
  study.gate_factor = passivity_stiffness_factor;
  study.max_damping = world::passivity_defaults::max_damping;
  ContactSetup setup;
  setup.mass = options.mass;
  setup.period_s = options.period_s;
  setup.hand = options.hand;
  setup.record_trace = true;
  for (const double factor : options.factors) {
    if (!(factor > 0.0) || !std::isfinite(factor))
      throw std::invalid_argument("a stiffness factor must be a finite number > 0");
    PassivityStudyRow row;
    row.factor = factor;
    row.stiffness = factor * study.fixed_gain_limit;
    const ContactHand& h = options.hand;
    row.static_penetration = h.stiffness * h.reference / (row.stiffness + h.stiffness);
    row.push_force = row.stiffness * row.static_penetration;
    row.off =
        summarize_contact(simulate_contact(wall_scene(options, row.stiffness, "off"), setup, row.stiffness),
                          row.stiffness, h, options.window_start_s);
    row.controller = summarize_contact(
        simulate_contact(wall_scene(options, row.stiffness, "controller"), setup, row.stiffness),
        row.stiffness, h, options.window_start_s);
    study.rows.push_back(std::move(row));
  }
  return study;
}

}  // namespace hapticd::analysis
