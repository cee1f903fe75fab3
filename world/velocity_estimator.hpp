#pragma once
/// \file
/// Velocity estimate from the measured position: the backward difference
/// v[n] = (y[n] - y[n-1]) / T used by Freudenberg (footnote 1 of 2.22) and by
/// Hulin's PD wall (the z^2 - 1 term of Hulin eq. 1 comes from it).

namespace hapticd::world {

class BackwardDifference {
 public:
  /// period_s must be > 0 (checked by the scene that owns the estimator).
  explicit BackwardDifference(double period_s) noexcept : inverse_period_(1.0 / period_s) {}

  /// Primes the estimator: the next update at the same position gives 0.
  void reset(double position) noexcept {
    previous_ = position;
    velocity_ = 0.0;
  }

  /// One period: returns (position - previous) / T and remembers position.
  double update(double position) noexcept {
    velocity_ = (position - previous_) * inverse_period_;
    previous_ = position;
    return velocity_;
  }

  double velocity() const noexcept { return velocity_; }
  double previous() const noexcept { return previous_; }
  double inverse_period() const noexcept { return inverse_period_; }

 private:
  double inverse_period_;
  double previous_ = 0.0;
  double velocity_ = 0.0;
};

}  // namespace hapticd::world
