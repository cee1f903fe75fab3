#include "skeleton_peer.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <stdexcept>

namespace hapticd::testing {

SkeletonPeer::SkeletonPeer(const drivers::simulation::PlantConfig& plant, double force_per_count,
                           double counts_per_unit)
    : plant_(plant),
      force_per_count_(force_per_count),
      position_per_count_((plant.motion == world::Motion::rotary ? 2.0 * std::numbers::pi : 1.0) /
                          counts_per_unit) {
  char dir[] = "/tmp/hapticd-skeleton-XXXXXX";
  if (::mkdtemp(dir) == nullptr) throw std::runtime_error("mkdtemp failed");
  dir_ = dir;
  path_ = dir_ + "/peer.sock";
  listener_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path_.c_str(), sizeof address.sun_path - 1);
  if (listener_ < 0 || ::bind(listener_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(listener_, 4) != 0)
    throw std::runtime_error("skeleton peer: cannot listen at " + path_);
  thread_ = std::thread([this] { serve(); });
}

SkeletonPeer::~SkeletonPeer() {
  stop_ = true;
  thread_.join();
  ::close(listener_);
  std::filesystem::remove_all(dir_);
}

void SkeletonPeer::serve() noexcept {
  // One connection at a time (each Device of a test connects anew).
  int connection = -1;
  while (!stop_) {
    pollfd p{connection >= 0 ? connection : listener_, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    if (connection < 0) {
      connection = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      continue;
    }
    std::uint8_t request[16];
    const ssize_t n = ::recv(connection, request, sizeof request, 0);
    if (n <= 0) {
      ::close(connection);
      connection = -1;
    } else if (n == 8) {
      answer(connection, request);
    }
  }
  if (connection >= 0) ::close(connection);
}

void SkeletonPeer::answer(int connection, const std::uint8_t* request) noexcept {
  // README.md: bytes 0-1 sequence (LE), byte 2 flags (bit 0 enable, bit 1
  // reset), byte 3 reserved, bytes 4-7 command counts (LE, signed).
  const bool enable = (request[2] & 1) != 0, reset = (request[2] & 2) != 0;
  std::uint32_t command_bits = 0;
  for (int i = 0; i < 4; ++i) command_bits |= static_cast<std::uint32_t>(request[4 + i]) << (8 * i);
  const auto command = static_cast<std::int32_t>(command_bits);
  if (reset) fault_code_ = 0;
  const std::uint8_t fault = fault_code_;
  const bool on = enable && fault == 0;
  plant_.step(on ? command * force_per_count_ : 0.0);
  double position = 0.0;
  (void)plant_.sense(position);
  const auto counts = static_cast<std::int32_t>(std::lround(position / position_per_count_));
  // Reply: bytes 0-1 the request's sequence, byte 2 status (bit 0 enabled,
  // bit 1 fault), byte 3 fault code, bytes 4-7 position counts (LE, signed).
  std::uint8_t reply[8] = {request[0], request[1],
                           static_cast<std::uint8_t>((on ? 1 : 0) | (fault != 0 ? 2 : 0)), fault};
  for (int i = 0; i < 4; ++i)
    reply[4 + i] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(counts) >> (8 * i));
  requests_.fetch_add(1);
  (void)::send(connection, reply, sizeof reply, MSG_NOSIGNAL);
}

}  // namespace hapticd::testing
