#include "sim/canopen/can_bus.hpp"

#include <linux/can.h>
#include <poll.h>

#include <array>

namespace hapticd::drivers::canopen::sim {

CanBus::CanBus(const std::string& path)
    : listener_(CanListener::listen(path, static_cast<int>(max_members))) {
  members_.reserve(max_members);
  closed_.reserve(max_members);
}

CanBus::~CanBus() { listener_.close(); }

void CanBus::run(const std::atomic<bool>& stop, std::chrono::microseconds tick) {
  while (!stop.load(std::memory_order_acquire)) poll_once(tick);
}

void CanBus::poll_once(std::chrono::microseconds wait) {
  std::array<pollfd, max_members + 1> fds{};
  fds[0] = {listener_.fd(), POLLIN, 0};
  for (std::size_t i = 0; i < members_.size(); ++i) fds[i + 1] = {members_[i].fd(), POLLIN, 0};
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(wait).count();
  if (::poll(fds.data(), members_.size() + 1, static_cast<int>(ms < 0 ? 0 : ms)) <= 0) return;
  // Frames first, in member order: a member that joins now hears what is sent from now on.
  for (std::size_t i = 0; i < members_.size(); ++i)
    if ((fds[i + 1].revents & (POLLIN | POLLHUP | POLLERR)) != 0) relay_from(i);
  drop_closed();
  if ((fds[0].revents & POLLIN) != 0) accept_members();
}

void CanBus::accept_members() {
  while (members_.size() < max_members) {
    CanSocket member = listener_.accept(std::chrono::microseconds(0));
    if (!member.is_open()) return;
    // Every frame passes, error frames (a drive's bus-off) included.
    member.set_filters({}, CAN_ERR_MASK);
    members_.push_back(std::move(member));
    closed_.push_back(false);
    member_count_.store(members_.size());
  }
}

void CanBus::relay_from(std::size_t from) {
  cia301::Frame frame;
  for (;;) {
    const IoStatus s = members_[from].receive(frame);
    if (s == IoStatus::ok) {
      relayed_.fetch_add(1);
      forward(from, frame);
    } else if (s == IoStatus::malformed) {
      malformed_.fetch_add(1);
    } else {
      if (s != IoStatus::would_block) closed_[from] = true;  // the member went away
      return;
    }
  }
}

void CanBus::forward(std::size_t from, const cia301::Frame& frame) {
  for (std::size_t to = 0; to < members_.size(); ++to) {
    if (to == from || closed_[to]) continue;
    const IoStatus s = members_[to].send(frame);
    if (s == IoStatus::would_block) dropped_.fetch_add(1);
    if (s == IoStatus::closed || s == IoStatus::error) closed_[to] = true;
  }
}

void CanBus::drop_closed() {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (closed_[i]) continue;
    if (kept != i) members_[kept] = std::move(members_[i]);
    ++kept;
  }
  members_.resize(kept);
  closed_.assign(kept, false);
  member_count_.store(kept);
}

}  // namespace hapticd::drivers::canopen::sim
