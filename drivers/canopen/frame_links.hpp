#pragma once
/// \file
/// The two ways the SDO client (sdo_client.hpp) reaches the drive on the
/// driver's socket, by which thread owns its receive side:
///  - SocketLink: before the RT loop runs (configure, enable, a stopped
///    loop): the client reads the socket itself; once the exchange exists,
///    the frames it does not want (TPDOs, EMCYs, heartbeats) go to the
///    exchange instead of being lost, and a message that is no frame
///    faults it;
///  - RingLink: while the loop runs: requests go straight out (send(2)
///    keeps message boundaries across threads); answers come from the
///    loop's read() through an SPSC ring.

#include <chrono>
#include <string>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/sdo_client.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::drivers::canopen {

class SocketLink final : public FrameLink {
 public:
  /// `exchange`: null before the exchange exists (the setup).
  explicit SocketLink(CanSocket& socket, CyclicExchange* exchange = nullptr)
      : socket_(socket), exchange_(exchange) {}
  bool send(const cia301::Frame& frame) override;
  bool receive(cia301::Frame& frame, std::chrono::steady_clock::time_point deadline) override;
  std::string link_error() const override { return error_; }

 private:
  CanSocket& socket_;
  CyclicExchange* exchange_;
  std::string error_;
};

class RingLink final : public FrameLink {
 public:
  /// Drops answers left in the ring from an earlier, timed-out transfer.
  RingLink(CanSocket& socket, rt::SpscRing<cia301::Frame>& ring);
  bool send(const cia301::Frame& frame) override;
  bool receive(cia301::Frame& frame, std::chrono::steady_clock::time_point deadline) override;

 private:
  CanSocket& socket_;
  rt::SpscRing<cia301::Frame>& ring_;
};

}  // namespace hapticd::drivers::canopen
