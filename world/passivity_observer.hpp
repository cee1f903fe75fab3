#pragma once
/// \file
/// Time-domain passivity observer and controller (Hannaford & Ryu, IEEE T-RA
/// 18(1), 2002) for one axis of a virtual environment, RT-safe: fixed
/// storage, no allocation, step() noexcept. Not yet part of any scene.
///
/// Observer (H&R, a one-port in impedance causality): per period
///   E[n] = E[n-1] + T f[n] v[n],
/// f the force the device applies TO the environment. hapticd's scenes return
/// the force ON the device, F = -f, so E += -T F v: energy the environment
/// absorbs counts positive, energy it generates negative. Passive iff E >= 0
/// from rest.
///
/// Stored energy: what the environment holds and will give back (the wall's
/// spring, 1/2 K x^2 while in contact) is its own, not credit: the observer
/// keeps the unstored balance D = E - S (S from the caller each period, >= 0)
/// and the controller acts when D < 0. A passive spring never drives D below
/// 0, so it is not damped when it returns its energy; an active one is caught
/// while still compressed, not only after the release.
///
/// Controller (H&R, the series damper for impedance causality): when
/// D < 0 it adds the damping alpha = -D / (T v^2), at most max_damping (what
/// the device can dissipate), to the force: F_out = F - alpha v. D is then
/// corrected by what that damper dissipates: H&R's alpha_applied T v^2 (with
/// the real v, not the floored one) at once (PassivityCorrection::estimated),
/// or what its force held over the next period really did, booked with the
/// next step (measured); either way a clamped alpha leaves the rest of D
/// negative for the next periods. D < 0 within the rounding of the energies
/// just subtracted (16 eps of them) is not acted on. v^2 in the gain is floored at
/// velocity_floor^2 (one encoder count per period, say): near v = 0 alpha
/// stays bounded, and at v = 0 exactly nothing is dissipated and D stays.
///
/// Forgetting (windowed observer, as sai2-primitives' POPC): each period's
/// contribution to D is kept for window_periods periods; when one leaves the
/// window, the energy it dissipated (a positive contribution) is forgotten,
/// as far as D stays >= 0 (forgetting never triggers the controller).
/// Generated energy (negative contributions) is never forgotten. Without
/// this, a long dissipative contact builds a credit that delays the
/// controller when the environment turns active. Stored energy is not in D,
/// so it is never forgotten either. window_periods = 0: never forget.
///
/// The velocity estimate: T v must be the displacement over the same period
/// as the force (T f v is then exactly the work). The backward difference
/// v[n] = (y[n] - y[n-1]) / T is that, the mean velocity over the last period
/// (T/2 late as a velocity at n). Which force to pair with it:
///  - H&R's pairing, f[n] from y[n] (the force computed this period): the
///    environment's own sampled passivity. A spring and a damper are passive
///    (D grows by 1/2 K dy^2 and B T v^2 per period); a delayed force or a
///    negative damper is active.
///  - the force held over that period (the previous output, after the scene's
///    delay): the zero-order hold's own activity shows too, 1/2 K dy^2 per
///    period for a sampled spring, and the controller then adds exactly
///    Colgate's K T / 2 (analysis/passivity.hpp).
/// The controller's damping force is applied with the next output, so it
/// acts T/2 + T after the mean velocity it is computed from.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace hapticd::world {

/// How the controller's own damping is booked (see the file comment).
enum class PassivityCorrection {
  /// H&R: alpha T v^2 at once, as if the velocity held over the next
  /// period. Exact for H&R's same-period pairing; blind to what the damper
  /// does when the velocity changes within the hold (near a turning point,
  /// or a damper too large for the device's mass and delay).
  estimated,
  /// The damper's force held over a period times the displacement over it,
  /// booked with the next step: what it really dissipated (or generated).
  measured,
};

struct PassivityObserverConfig {
  double period_s = 1e-3;        ///< T, s, > 0
  double max_damping = 0.0;      ///< N s/m (N m s/rad): the most the controller adds, >= 0
  double velocity_floor = 1e-3;  ///< m/s (rad/s), > 0: v^2 in alpha is at least this squared
  /// m/s (rad/s), >= 0: the controller does not act while |v| <= this. One
  /// encoder count a period is quantization, and a damper acting on it T/2 + T
  /// late dithers the device between two counts and books that as generated
  /// energy, so it never stops (0.094 N at 30 N s/m on the loopback's 3.14 um
  /// counts, after the hand let go). D is kept for the next faster period.
  /// 0: no deadband.
  double velocity_deadband = 0.0;
  std::size_t window_periods = 0;  ///< forget dissipated energy older than this; 0: never
  /// Periods the device adds between the force a step returns and the period
  /// it is held over (CiA 402 cyclic: the next SYNC), <= max_output_delay:
  /// the controller's own force is booked against the displacement of the
  /// period it really acted in.
  std::size_t output_delay_periods = 0;
  bool control = true;  ///< false: observe only (alpha always 0)
  PassivityCorrection correction = PassivityCorrection::estimated;
};

/// The longest device delay the observer pairs across, in periods.
inline constexpr std::size_t max_output_delay = 16;

/// Forces on their way to a device that adds `delay` periods: acting() is
/// the one held over the period that just ended (pushed 1 + delay steps
/// ago), and push() puts this step's in its place. Fixed storage, RT-safe.
class ForcesInFlight {
 public:
  explicit ForcesInFlight(std::size_t delay = 0) noexcept : length_(std::min(delay, max_output_delay) + 1) {}
  double acting() const noexcept { return forces_[head_]; }
  void push(double force) noexcept {
    forces_[head_] = force;
    head_ = (head_ + 1) % length_;
  }
  void clear() noexcept {
    forces_.fill(0.0);
    head_ = 0;
  }

 private:
  std::array<double, max_output_delay + 1> forces_{};
  std::size_t length_ = 1;
  std::size_t head_ = 0;
};

/// The velocity floor of one encoder count per period: resolution / T.
constexpr double velocity_floor_for(double position_resolution, double period_s) noexcept {
  return position_resolution / period_s;
}

/// What one period added.
struct PassivityStep {
  double damping = 0.0;  ///< alpha applied, N s/m (0 when the controller did not act)
  double force = 0.0;    ///< the controller's force on the device, -alpha v (add it to the scene's)
  /// J: estimated, alpha T v^2 of this period's damper; measured, what the
  /// previous period's damper did over the period that just ended.
  double dissipated = 0.0;
};

/// Capacity: the longest window it can hold, in periods (its storage).
template <std::size_t Capacity = 256>
class PassivityObserver {
  static_assert(Capacity > 0);

 public:
  static constexpr std::size_t window_capacity = Capacity;

  /// Off the RT path. Throws std::invalid_argument on T <= 0, max_damping < 0,
  /// velocity_floor <= 0 (any not finite) or window_periods > Capacity.
  explicit PassivityObserver(const PassivityObserverConfig& config)
      : config_(config), own_forces_(config.output_delay_periods) {
    const auto finite_positive = [](double x) { return std::isfinite(x) && x > 0.0; };
    if (!finite_positive(config.period_s))
      throw std::invalid_argument("passivity observer: period must be > 0");
    if (!(std::isfinite(config.max_damping) && config.max_damping >= 0.0))
      throw std::invalid_argument("passivity observer: max_damping must be >= 0 (N s/m)");
    if (!finite_positive(config.velocity_floor))
      throw std::invalid_argument("passivity observer: velocity_floor must be > 0 (m/s)");
    if (!(std::isfinite(config.velocity_deadband) && config.velocity_deadband >= 0.0))
      throw std::invalid_argument("passivity observer: velocity_deadband must be >= 0 (m/s)");
    if (config.output_delay_periods > max_output_delay)
      throw std::invalid_argument("passivity observer: output_delay_periods must be <= " +
                                  std::to_string(max_output_delay));
    if (config.window_periods > Capacity)
      throw std::invalid_argument("passivity observer: window_periods exceeds the capacity of " +
                                  std::to_string(Capacity));
    // At least the smallest normal double: a floor of 1e-300 m/s must not square to 0.
    floor_squared_ =
        std::max(config.velocity_floor * config.velocity_floor, std::numeric_limits<double>::min());
  }

  /// Back to the start: no energy absorbed, an empty window, and the energy
  /// the environment holds now (J: a wall loaded with the device inside it,
  /// a stretched spring), so that giving it back is not read as generated.
  void reset(double stored_energy = 0.0) noexcept {
    unstored_ = 0.0;
    stored_ = std::isfinite(stored_energy) && stored_energy > 0.0 ? stored_energy : 0.0;
    damping_ = 0.0;
    own_forces_.clear();
    head_ = 0;
    size_ = 0;
  }

  /// One period. force: the environment's force ON the device (N), without
  /// this controller's; velocity: the device's over the same period (m/s);
  /// stored_energy: what the environment holds now (J, >= 0). A period with
  /// any of them not finite (or stored_energy < 0) is skipped and counted in
  /// rejected(): no energy, no damping.
  PassivityStep step(double force, double velocity, double stored_energy = 0.0) noexcept {
    if (!std::isfinite(force) || !std::isfinite(velocity) || !std::isfinite(stored_energy) ||
        stored_energy < 0.0) {
      ++rejected_;
      damping_ = 0.0;
      own_forces_.push(0.0);
      return {};
    }
    const double t = config_.period_s;
    // H&R's observer with f = -F, minus what went into storage this period.
    const double flow = -t * force * velocity;
    double contribution = flow - (stored_energy - stored_);
    // Below this, D < 0 is rounding of the energies just subtracted, not generated energy.
    const double rounding = 16.0 * std::numeric_limits<double>::epsilon() *
                            (std::abs(flow) + stored_energy + stored_ + std::abs(unstored_));
    stored_ = stored_energy;
    PassivityStep out;
    if (config_.correction == PassivityCorrection::measured) {
      // What the damper's force held over this period really did.
      out.dissipated = -t * own_forces_.acting() * velocity;
      contribution += out.dissipated;
    }
    unstored_ += contribution;
    const bool moving = config_.velocity_deadband == 0.0 || std::abs(velocity) > config_.velocity_deadband;
    if (config_.control && unstored_ < -rounding && moving) {
      const double v2 = velocity * velocity;
      const double gain = -unstored_ / (t * std::max(v2, floor_squared_));  // H&R's gain
      out.damping = std::min(gain, config_.max_damping);
      out.force = -out.damping * velocity;
      if (config_.correction == PassivityCorrection::estimated) {
        out.dissipated = out.damping * t * v2;  // H&R: at once, as if v held over the next period
        unstored_ += out.dissipated;
        contribution += out.dissipated;
      }
    }
    damping_ = out.damping;
    own_forces_.push(out.force);
    remember(contribution);
    return out;
  }

  /// E, J: the energy the environment has absorbed (after corrections and
  /// forgetting), plus what it held at reset().
  double energy() const noexcept { return unstored_ + stored_; }
  /// D = E - S, J: what the controller acts on (< 0: the environment has generated energy).
  double unstored_energy() const noexcept { return unstored_; }
  double stored_energy() const noexcept { return stored_; }
  /// alpha of the last period, N s/m.
  double damping() const noexcept { return damping_; }
  /// Periods skipped for non-finite input.
  std::size_t rejected() const noexcept { return rejected_; }
  const PassivityObserverConfig& config() const noexcept { return config_; }

 private:
  /// Keeps the contribution; forgets the dissipation of the one leaving the window.
  void remember(double contribution) noexcept {
    const std::size_t window = config_.window_periods;
    if (window == 0) return;
    if (size_ == window) {
      const double oldest = window_[head_];
      // Only dissipated energy is forgotten, and only as far as D stays >= 0.
      if (oldest > 0.0 && unstored_ > 0.0) unstored_ -= std::min(oldest, unstored_);
      head_ = (head_ + 1) % window;
      --size_;
    }
    window_[(head_ + size_) % window] = contribution;
    ++size_;
  }

  PassivityObserverConfig config_;
  double floor_squared_ = 0.0;
  double unstored_ = 0.0;
  double stored_ = 0.0;
  double damping_ = 0.0;
  ForcesInFlight own_forces_;  ///< the controller's, for the measured correction
  std::size_t rejected_ = 0;
  std::array<double, Capacity> window_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace hapticd::world
