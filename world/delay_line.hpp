#pragma once
/// \file
/// Fixed-capacity output delay: push(x[n]) returns x[n - d]. No allocation.

#include <array>
#include <cstddef>

namespace hapticd::world {

template <std::size_t Capacity>
class DelayLine {
  static_assert(Capacity > 0);

 public:
  static constexpr std::size_t capacity = Capacity;

  /// delay_samples in 1..Capacity (checked by the owner, off the RT path).
  explicit DelayLine(std::size_t delay_samples) noexcept
      : delay_(delay_samples < 1 ? 1 : (delay_samples > Capacity ? Capacity : delay_samples)) {}

  /// Fills the line with zeros: the next d pushes return 0.
  void reset() noexcept {
    buffer_.fill(0.0);
    index_ = 0;
  }

  /// Stores value (computed at n) and returns the value pushed at n - d.
  double push(double value) noexcept {
    const double out = buffer_[index_];
    buffer_[index_] = value;
    if (++index_ == delay_) index_ = 0;
    return out;
  }

  std::size_t delay() const noexcept { return delay_; }

 private:
  std::array<double, Capacity> buffer_{};
  std::size_t delay_;
  std::size_t index_ = 0;
};

}  // namespace hapticd::world
