#include "sim/canopen/drive_bus.hpp"

#include <poll.h>

#include <algorithm>

#include "sim/canopen/commands.hpp"

namespace hapticd::drivers::canopen::sim {

DriveBus::DriveBus(const std::string& path, SimulatedDrive& drive)
    : drive_(drive), listener_(CanListener::listen(path)) {
  std::vector<Frame> out;
  drive_.power_on(now(), out);  // the boot-up goes nowhere: no driver yet
}

DriveBus::DriveBus(Member, const std::string& path, SimulatedDrive& drive)
    : drive_(drive), member_(true), bus_path_(path) {
  // Every frame on the bus reaches the drive; it keeps what CiA 301 addresses to it.
  connection_ = CanSocket::open("unix:" + path, {}, 0);
  connections_ = 1;
  std::vector<Frame> out;
  drive_.power_on(now(), out);
  send_all(out);
}

DriveBus::~DriveBus() { listener_.close(); }

Micros DriveBus::now() const {
  return std::chrono::duration_cast<Micros>(std::chrono::steady_clock::now() - epoch_);
}

bool DriveBus::connected() const {
  std::lock_guard lock(mutex_);
  return connection_.is_open();
}

double DriveBus::applied_force() const {
  std::lock_guard lock(mutex_);
  return drive_.applied_force();
}

void DriveBus::send_all(const std::vector<Frame>& frames) {
  for (const Frame& f : frames) {
    if (!connection_.is_open()) return;
    if (connection_.send(f) == IoStatus::closed) connection_.close();
  }
}

void DriveBus::poll_once(std::chrono::microseconds wait) {
  int fd = -1;
  {
    std::lock_guard lock(mutex_);
    fd = connection_.is_open() ? connection_.fd() : listener_.fd();  // -1 (a member cut off): poll waits
    const Micros next = drive_.next_deadline();
    const Micros t = now();
    if (next > t)
      wait = std::min(wait, std::chrono::duration_cast<std::chrono::microseconds>(next - t));
    else
      wait = std::chrono::microseconds(0);
  }
  pollfd p{fd, POLLIN, 0};
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(wait).count();
  (void)::poll(&p, 1, static_cast<int>(ms));

  std::lock_guard lock(mutex_);
  std::vector<Frame> out;
  if (!connection_.is_open()) {
    if (member_) return;  // the bus ended: no one to hear the drive
    connection_ = listener_.accept(std::chrono::microseconds(0));
    if (connection_.is_open()) ++connections_;
  } else {
    Frame f;
    for (;;) {
      const IoStatus s = connection_.receive(f);
      if (s == IoStatus::ok) {
        out.clear();
        drive_.on_frame(f, now(), out);
        send_all(out);
        continue;
      }
      if (s != IoStatus::would_block) connection_.close();  // the driver went away
      break;
    }
  }
  out.clear();
  drive_.tick(now(), out);
  send_all(out);
}

void DriveBus::run(const std::atomic<bool>& stop, std::chrono::microseconds tick) {
  while (!stop.load(std::memory_order_acquire)) poll_once(tick);
}

std::string DriveBus::command(const std::string& line) {
  std::lock_guard lock(mutex_);
  std::vector<Frame> out;
  std::string reply = apply_command(drive_, line, now(), out);
  send_all(out);
  return reply;
}

}  // namespace hapticd::drivers::canopen::sim
