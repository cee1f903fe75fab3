#include "analysis/passivity_contact.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace hapticd::analysis {

namespace {

/// x[n+1] = ad x[n] + bd u for m y'' = u - b y' under the zero-order hold.
struct RigidStep {
  std::array<double, 3> ad{};  ///< [1, a01; 0, a11]
  std::array<double, 2> bd{};
};

RigidStep rigid_step(double m, double b, double t) {
  RigidStep s;
  if (b > 0.0) {
    const double decay = std::exp(-b * t / m);
    s.ad = {(1.0 - decay) * m / b, 0.0, decay};
    s.bd = {(t - (1.0 - decay) * m / b) / b, (1.0 - decay) / b};
  } else {
    s.ad = {t, 0.0, 1.0};
    s.bd = {t * t / (2.0 * m), t / m};
  }
  return s;
}

/// The index of the passivity_damping channel of this scene, if it has one.
std::optional<std::size_t> damping_channel(const world::AnyScene& scene) {
  return std::visit(
      [](const auto& s) -> std::optional<std::size_t> {
        using S = std::remove_cvref_t<decltype(s)>;
        for (std::size_t i = 0; i < S::channel_count; ++i) {
          if (S::channel_names[i] == std::string_view("passivity_damping")) return i;
        }
        return std::nullopt;
      },
      scene);
}

ContactWindow window_of(const std::vector<double>& penetration) {
  if (penetration.empty()) return {};
  const auto [low, high] = std::minmax_element(penetration.begin(), penetration.end());
  double sum = 0.0;
  for (const double p : penetration) sum += p;
  return {sum / static_cast<double>(penetration.size()), (*high - *low) / 2.0};
}

}  // namespace

ContactRun simulate_contact(world::AnyScene scene, const ContactSetup& setup, double wall_stiffness) {
  const double t = setup.period_s;
  const RigidStep plant = rigid_step(setup.mass, setup.device_damping, t);
  const auto damping_index = damping_channel(scene);
  std::array<double, world::max_scene_channels> channels{};
  ContactRun run;
  const ContactHand& hand = setup.hand;
  run.static_penetration = hand.stiffness * hand.reference / (wall_stiffness + hand.stiffness);
  std::vector<double> early;
  std::vector<double> late;
  double y = setup.start;
  double v = 0.0;
  world::reset(scene, y);
  // The forces on their way to the device: the one acting now is delay steps old.
  std::vector<double> on_the_way(static_cast<std::size_t>(std::max(setup.device_delay, 0)) + 1, 0.0);
  std::size_t way = 0;
  const auto steps = static_cast<std::size_t>(std::llround(setup.duration_s / t));
  for (std::size_t n = 0; n < steps; ++n) {
    const double time = static_cast<double>(n) * t;
    const double force = world::step(scene, y);
    double alpha = 0.0;
    if (damping_index) {
      world::channels(scene, channels);
      alpha = channels[*damping_index];
      run.peak_passivity_damping = std::max(run.peak_passivity_damping, alpha);
    }
    run.peak_force = std::max(run.peak_force, std::abs(force));
    const bool pushing = time < hand.release_s;
    if (setup.record_trace) run.trace.push_back({time, y, force, alpha, pushing});
    if (pushing && time >= 0.2 && time < 0.3) early.push_back(y);
    if (pushing && time >= hand.release_s - 0.1) late.push_back(y);
    if (!pushing && time < hand.release_s + 0.1 + t / 2) run.release_velocity = v;
    const double hand_force = pushing ? hand.stiffness * (hand.reference - y) - hand.damping * v : 0.0;
    on_the_way[way] = force;
    way = (way + 1) % on_the_way.size();
    const double acting = on_the_way[way];
    const double u = acting + hand_force;
    const double next_y = y + plant.ad[0] * v + plant.bd[0] * u;
    v = plant.ad[2] * v + plant.bd[1] * u;
    y = next_y;
    if (!(std::abs(y) <= 1.0) || !(std::abs(force) <= 1e6) || !std::isfinite(v)) {
      run.diverged = true;
      run.diverged_at_s = time;
      break;
    }
  }
  run.early = window_of(early);
  run.late = window_of(late);
  return run;
}

}  // namespace hapticd::analysis
