#pragma once
/// \file
/// A request from the control thread that the RT loop takes at its next
/// read() (a disable: the drive's Controlword goes out with the next SYNC),
/// shared by one drive (CanopenDevice) and a bus of drives (CanopenBusDevice).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

namespace hapticd::drivers::canopen {

/// Waits until the loop has taken `requested` (it clears it) and run three
/// more periods, so that what it sends goes out; 200 ms at most (a loop
/// that stopped meanwhile does not hold the caller). Not for the RT thread.
inline void await_loop_handover(const std::atomic<bool>& requested,
                                const std::atomic<std::uint64_t>& reads) noexcept {
  const std::uint64_t seen = reads.load(std::memory_order_acquire);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(200);
  while (std::chrono::steady_clock::now() < deadline &&
         (requested.load(std::memory_order_acquire) || reads.load(std::memory_order_acquire) < seen + 3))
    std::this_thread::sleep_for(std::chrono::microseconds(200));
}

}  // namespace hapticd::drivers::canopen
