#pragma once
/// \file
/// The skeleton driver's simulated peer, for its tests: a SOCK_SEQPACKET
/// listener at a temporary path and one thread that answers each request by
/// advancing the shared plant simulator one period (DRIVERS.md: one period
/// per exchange). It reads and writes the wire with its own few lines, from
/// README.md's table, not with the driver's codec: a misreading of the
/// table in either would show as a failure.

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "drivers/simulation/plant_simulator.hpp"

namespace hapticd::testing {

class SkeletonPeer {
 public:
  /// force_per_count and counts_per_unit as in the driver's config.
  SkeletonPeer(const drivers::simulation::PlantConfig& plant, double force_per_count, double counts_per_unit);
  ~SkeletonPeer();
  SkeletonPeer(const SkeletonPeer&) = delete;
  SkeletonPeer& operator=(const SkeletonPeer&) = delete;

  const std::string& path() const noexcept { return path_; }
  /// The peer latches a fault with `code`: output off, every reply says so,
  /// until a request with the reset flag.
  void inject_fault(std::uint8_t code) noexcept { fault_code_.store(code); }
  /// The force the plant applies now (N or N m).
  double applied_force() const noexcept { return plant_.snapshot().applied_force; }
  std::uint64_t requests() const noexcept { return requests_.load(); }

 private:
  void serve() noexcept;
  void answer(int connection, const std::uint8_t* request) noexcept;

  drivers::simulation::PlantSimulator plant_;
  double force_per_count_, position_per_count_;
  std::string dir_, path_;
  int listener_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint8_t> fault_code_{0};
  std::atomic<std::uint64_t> requests_{0};
  std::thread thread_;
};

}  // namespace hapticd::testing
