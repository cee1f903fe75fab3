// One run of the accuracy study: a world scene (or Odeint) on the held step,
// compared with the closed form sample by sample.

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "analysis/accuracy_tracker.hpp"
#include "analysis/odeint_reference.hpp"
#include "world/integrator.hpp"
#include "world/spring_scene.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::analysis {

namespace detail {

ErrorTracker::ErrorTracker(const AccuracyCase& c, const RunOptions& options, RunResult& result)
    : case_(c),
      reference_(reference_problem(c, options.period_s)),
      period_s_(options.period_s),
      scale_(output_scale(c)),
      result_(result),
      per_decade_(options.growth_points_per_decade) {
  if (options.checkpoints_s.empty()) throw std::invalid_argument("accuracy run needs a duration");
  for (const double t : options.checkpoints_s) {
    checkpoint_index_.push_back(std::max(0L, std::lround(t / options.period_s)));
  }
  last_ = checkpoint_index_.back();
  result_.errors.assign(checkpoint_index_.size(), 0.0);
  result_.growth.clear();
}

bool ErrorTracker::observe(long n, double output) {
  const double exact = reference_output(case_, reference_, n, period_s_);
  const double error =
      std::isfinite(output) ? std::abs(output - exact) / scale_ : std::numeric_limits<double>::infinity();
  if (!(error <= running_max_)) running_max_ = error;  // NaN-safe: a NaN error counts as larger
  while (next_checkpoint_ < checkpoint_index_.size() && checkpoint_index_[next_checkpoint_] == n) {
    result_.errors[next_checkpoint_++] = running_max_;
  }
  if (per_decade_ > 0 && n == next_growth_index_) {
    result_.growth.push_back({static_cast<double>(n) * period_s_, running_max_});
    // Next log-spaced index strictly after n.
    while (next_growth_index_ <= n) {
      ++next_growth_;
      next_growth_index_ = std::lround(std::pow(10.0, static_cast<double>(next_growth_) / per_decade_));
    }
  }
  result_.periods = n + 1;
  return std::isfinite(error);
}

void ErrorTracker::finish(long observed) {
  for (std::size_t i = next_checkpoint_; i < checkpoint_index_.size(); ++i) {
    result_.errors[i] =
        observed < checkpoint_index_[i] ? std::numeric_limits<double>::infinity() : running_max_;
  }
}

}  // namespace detail

namespace {

using detail::ErrorTracker;
using detail::time_per_step;

constexpr long progress_chunk = 1L << 16;

/// Periods already reported as progress after n periods (whole chunks).
long whole_chunks(long n) { return (n / progress_chunk) * progress_chunk; }

template <class Scene>
RunResult run_spring(const AccuracyCase& c, const Scene& initial, const RunOptions& options,
                     StudyProgress& progress) {
  RunResult result;
  result.cpu_s_per_step = std::numeric_limits<double>::quiet_NaN();
  ErrorTracker tracker(c, options, result);
  Scene scene = initial;
  scene.reset(0.0);
  long n = 0;
  for (; n <= tracker.last(); ++n) {
    if (!tracker.observe(n, scene.step(c.step))) break;
    if ((n + 1) % progress_chunk == 0) progress.advance(progress_chunk);
  }
  tracker.finish(n);
  progress.advance(static_cast<double>(tracker.last() + 1 - whole_chunks(n)));
  if (options.timing_steps <= 0) return result;
  Scene timed = initial;
  timed.reset(0.0);
  const double z0 = c.step;
  result.cpu_s_per_step =
      time_per_step([&](long) noexcept { return timed.step(z0); }, options.timing_steps, progress.clock());
  return result;
}

template <class Wall>
RunResult run_wall(const AccuracyCase& c, const Wall& initial, const RunOptions& options,
                   StudyProgress& progress) {
  RunResult result;
  result.cpu_s_per_step = std::numeric_limits<double>::quiet_NaN();
  ErrorTracker tracker(c, options, result);
  const double t = options.period_s;
  const world::DiscreteStateSpace zoh = world::discretize_zoh(c.device.model().dynamics, t);
  const Eigen::Matrix2d phi = zoh.ad;
  const Eigen::Vector2d motor = zoh.bd.col(world::motor_force_input);
  const Eigen::Vector2d hand = zoh.bd.col(world::hand_force_input) * c.step;
  // The first inputs, replayed into a fresh wall to time its step alone.
  std::vector<double> replay;
  replay.reserve(static_cast<std::size_t>(std::min(options.timing_steps, tracker.last() + 1)));

  Wall wall = initial;
  wall.reset(0.0);  // at the surface: armed
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  double previous = 0.0;
  long n = 0;
  for (; n <= tracker.last(); ++n) {
    const double y = x(0);
    const double force = wall.step(y);
    if (!tracker.observe(n, force)) break;
    if (n >= 1) {
      // The linear law held only while penetrating and pushing (not clamped).
      const double law = -c.stiffness * y - c.damping * (y - previous) / t;
      if (!(y > 0.0) || law > 0.0) result.contact_kept = false;
    }
    if (static_cast<long>(replay.size()) < options.timing_steps) replay.push_back(y);
    x = phi * x + motor * force + hand;
    previous = y;
    if ((n + 1) % progress_chunk == 0) progress.advance(progress_chunk);
  }
  tracker.finish(n);
  progress.advance(static_cast<double>(tracker.last() + 1 - whole_chunks(n)));
  if (options.timing_steps <= 0 || replay.empty()) return result;
  Wall timed = initial;
  timed.reset(0.0);
  const auto size = static_cast<long>(replay.size());
  result.cpu_s_per_step = time_per_step(
      [&](long i) noexcept {
        const long k = i % size;
        if (k == 0) timed.reset(0.0);
        return timed.step(replay[static_cast<std::size_t>(k)]);
      },
      options.timing_steps, progress.clock());
  return result;
}

RunResult run_spring_case(const AccuracyCase& c, world::Integrator integrator, const RunOptions& options,
                          StudyProgress& progress) {
  using world::SpringDamping;
  using world::SpringScene;
  const world::SpringParameters p{c.stiffness, c.inertia, c.damping, integrator};
  const double t = options.period_s;
  if (c.damping == 0.0) return run_spring(c, SpringScene<SpringDamping::none>(p, t), options, progress);
  if (c.scene == AccuracyScene::spring_wheel_absolute) {
    return run_spring(c, SpringScene<SpringDamping::absolute>(p, t), options, progress);
  }
  return run_spring(c, SpringScene<SpringDamping::relative>(p, t), options, progress);
}

world::WallParameters wall_parameters(const AccuracyCase& c) {
  world::WallParameters p;
  p.stiffness = c.stiffness;
  p.damping = c.damping;
  p.position = 0.0;
  p.side = world::WallSide::upper;
  p.delay_samples = c.delay_samples;
  return p;
}

/// Calls f with the wall variant the catalog would build for these parameters.
template <class F>
auto with_wall(const AccuracyCase& c, double period_s, F&& f) {
  using world::WallDamping;
  using world::WallDelay;
  using world::WallScene;
  const world::WallParameters p = wall_parameters(c);
  const bool damped = c.damping != 0.0;
  const bool delayed = c.delay_samples != 0;
  if (damped && delayed)
    return f(WallScene<WallDamping::backward_difference, WallDelay::samples>(p, period_s));
  if (damped) return f(WallScene<WallDamping::backward_difference, WallDelay::none>(p, period_s));
  if (delayed) return f(WallScene<WallDamping::none, WallDelay::samples>(p, period_s));
  return f(WallScene<WallDamping::none, WallDelay::none>(p, period_s));
}

}  // namespace

world::DiscreteLinearScene detail::wall_linear_model(const AccuracyCase& c, double period_s) {
  return with_wall(c, period_s, [](const auto& wall) { return wall.linear_model(); });
}

RunResult run_method(const AccuracyCase& c, const Method& method, const RunOptions& options,
                     StudyProgress& progress) {
  RunResult result;
  switch (method.kind) {
    case Method::Kind::integrator:
      if (!has_integrator(c.scene)) throw std::invalid_argument("the wall has no integrator");
      result = run_spring_case(c, method.integrator, options, progress);
      break;
    case Method::Kind::sampled_wall:
      if (has_integrator(c.scene)) throw std::invalid_argument("sampled-wall is the wall's own method");
      result = with_wall(c, options.period_s,
                         [&](const auto& wall) { return run_wall(c, wall, options, progress); });
      break;
    case Method::Kind::odeint_rk4:
    case Method::Kind::odeint_dopri5:
      return run_odeint(c, method, options, progress);
  }
  result.solver_steps = result.periods;
  result.cpu_s_per_simulated_s = result.cpu_s_per_step / options.period_s;
  result.stable = discretization_stable(c, method, options.period_s);
  return result;
}

}  // namespace hapticd::analysis
