#include "world/task_walls.hpp"

namespace hapticd::world {

TaskForceDelay::TaskForceDelay(int delay_samples, Eigen::Index dimensions) : delay_(delay_samples) {
  if (delay_samples < 1 || delay_samples > static_cast<int>(max_wall_delay_samples))
    throw std::invalid_argument("delay: 1 to " + std::to_string(max_wall_delay_samples) + " samples");
  for (AxisVector& f : buffer_) f.setZero(dimensions);
}

void TaskForceDelay::reset() noexcept {
  for (AxisVector& f : buffer_) f.setZero();
  index_ = 0;
}

void TaskForceDelay::push(AxisVector& force) noexcept {
  AxisVector& slot = buffer_[static_cast<std::size_t>(index_)];
  slot.swap(force);  // the slot keeps F[n]; force gets F[n - d]
  if (++index_ == delay_) index_ = 0;
}

namespace detail {

AxisVector unit_normal(const AxisVector& direction) {
  if (direction.size() < 1 || !direction.allFinite() || direction.norm() == 0.0)
    throw std::invalid_argument("plane-wall: the normal must be a finite, non-zero direction");
  return direction.normalized();
}

}  // namespace detail

}  // namespace hapticd::world
