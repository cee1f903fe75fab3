// The registry entry of `relay` (world/scene_registry.hpp): the on-off
// controller of Diaz & Gil's relay experiment, its units following the
// device's motion. The scene itself is header-only (relay_scene.hpp).

#include "world/relay_scene.hpp"

#include <cmath>
#include <cstdint>

#include "world/scene_catalog.hpp"

namespace hapticd::world {

namespace {

using P = ParameterSpec;

std::vector<ParameterSpec> relay_parameters() {
  namespace d = scene_defaults;
  namespace r = parameter_range;
  return {
      P::number("amplitude", "N", "relay amplitude h")
          .on_rotary("N m")
          .defaults_to(d::relay_amplitude)
          .at_least(0.0)
          .at_most(r::max_force),
      P::number("hysteresis", "m", "hysteresis half-width eps")
          .on_rotary("rad")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(r::max_position),
      P::number("reference", "m", "reference position")
          .on_rotary("rad")
          .defaults_to(0.0)
          .at_least(-r::max_position)
          .at_most(r::max_position),
      P::integer("delay", "samples", "extra loop delay t_d in periods (Diaz & Gil eq. 25)")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(static_cast<double>(max_relay_delay_samples)),
      P::number("duration", "s", "stop by itself (output 0) after this long; 0: run until replaced")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(r::max_duration_s),
  };
}

/// The variant without a band when eps = 0, without a delay line when d = 0.
void build_relay(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  RelayParameters rp{number_of(p, "amplitude"), number_of(p, "hysteresis"), number_of(p, "reference")};
  rp.delay_samples = static_cast<int>(number_of(p, "delay"));
  const double duration = number_of(p, "duration");
  rp.duration_steps = static_cast<std::int64_t>(std::llround(duration / context.period_s));
  if (duration > 0.0 && rp.duration_steps < 1) rp.duration_steps = 1;
  const bool band = rp.hysteresis != 0.0;
  using H = RelayHysteresis;
  using D = RelayDelay;
  if (rp.delay_samples == 0) {
    band ? set_scene(plan, RelayScene<H::band>(rp), context.motion)
         : set_scene(plan, RelayScene<H::none>(rp), context.motion);
  } else if (band) {
    set_scene(plan, RelayScene<H::band, D::samples>(rp), context.motion);
  } else {
    set_scene(plan, RelayScene<H::none, D::samples>(rp), context.motion);
  }
}

}  // namespace

SceneDescription RelayEntry::describe() {
  return {.name = "relay",
          .reference = "Diaz & Gil, section V (relay experiment)",
          .summary = "F = -h sign(y - reference), optional hysteresis band",
          .parameters = relay_parameters(),
          .fixed_motion = std::nullopt,
          .stability = StabilityRule::none,
          .unstable_hint = {},
          .build = build_relay};
}

}  // namespace hapticd::world
