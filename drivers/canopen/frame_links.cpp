#include "drivers/canopen/frame_links.hpp"

#include <thread>

namespace hapticd::drivers::canopen {

using cia301::Frame;
using Clock = std::chrono::steady_clock;

bool SocketLink::send(const Frame& frame) {
  const IoStatus s = socket_.send(frame);
  if (s == IoStatus::closed) error_ = "the bus connection closed";
  return s == IoStatus::ok;
}

bool SocketLink::receive(Frame& frame, Clock::time_point deadline) {
  for (;;) {
    const IoStatus s = socket_.receive(frame);
    if (s == IoStatus::ok) {
      if (exchange_ == nullptr || exchange_->on_frame(frame) == FrameUse::sdo_response) return true;
      continue;
    }
    if (s == IoStatus::malformed) {
      if (exchange_ != nullptr) exchange_->on_malformed_message(socket_.last_malformed());
      error_ = describe(socket_.last_malformed());
      return false;
    }
    if (s == IoStatus::closed) {
      error_ = "the bus connection closed";
      return false;
    }
    if (s == IoStatus::error) {
      error_ = "socket error " + std::to_string(socket_.last_errno());
      return false;
    }
    const auto now = Clock::now();
    if (now >= deadline) return false;
    socket_.wait_readable(std::chrono::duration_cast<std::chrono::microseconds>(deadline - now));
  }
}

RingLink::RingLink(CanSocket& socket, rt::SpscRing<Frame>& ring) : socket_(socket), ring_(ring) {
  Frame stale;
  while (ring_.try_pop(stale)) {
  }
}

bool RingLink::send(const Frame& frame) { return socket_.send(frame) == IoStatus::ok; }

bool RingLink::receive(Frame& frame, Clock::time_point deadline) {
  for (;;) {
    if (ring_.try_pop(frame)) return true;
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
}

}  // namespace hapticd::drivers::canopen
