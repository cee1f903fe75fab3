#pragma once
/// \file
/// The SDO client (non-RT: configuration and commissioning). SdoExchange is
/// one expedited transfer as pure logic: the request frame, which response
/// completes it (same server, same index and sub-index: a stale answer to an
/// earlier, timed-out request is ignored), and the outcome in words.
/// SdoClient runs exchanges one at a time over a FrameLink with a timeout;
/// on a timeout it aborts the transfer (0x05040000) as CiA 301 asks.

#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/301/object.hpp"
#include "drivers/canopen/301/sdo.hpp"
#include "drivers/stop_request.hpp"

namespace hapticd::drivers::canopen {

struct SdoOutcome {
  enum class Kind : std::uint8_t { pending, ok, aborted, timed_out, unsupported };
  Kind kind = Kind::pending;
  std::uint32_t value = 0;  ///< upload: the raw value
  std::uint8_t size = 0;    ///< upload: bytes indicated (0 = not indicated)
  std::uint32_t abort_code = 0;
  std::string detail;  ///< unsupported: what the server answered instead
};

class SdoExchange {
 public:
  static SdoExchange upload(std::uint8_t node, cia301::ObjectAddress address);
  /// size: 1..4 bytes, the object's type size.
  static SdoExchange download(std::uint8_t node, cia301::ObjectAddress address, std::uint32_t value,
                              std::uint8_t size);

  const cia301::Frame& request() const noexcept { return request_; }
  /// A frame from the bus; true when it completed the exchange. `reply` is
  /// set when the client must answer (an abort for a transfer it cannot do).
  bool on_frame(const cia301::Frame& frame, std::optional<cia301::Frame>& reply);
  /// The client gives up: the outcome becomes timed_out; returns the abort to send.
  cia301::Frame time_out();
  const SdoOutcome& outcome() const noexcept { return outcome_; }
  bool done() const noexcept { return outcome_.kind != SdoOutcome::Kind::pending; }

  /// One line: "SDO write 0x6060:00 = 10 to node 5: aborted 0x06090030 (invalid value for the parameter)".
  std::string describe() const;
  bool is_upload() const noexcept { return upload_; }
  cia301::ObjectAddress address() const noexcept { return address_; }

 private:
  SdoExchange() = default;
  std::uint8_t node_ = 0;
  cia301::ObjectAddress address_;
  bool upload_ = true;
  std::uint32_t value_ = 0;
  std::uint8_t size_ = 0;
  cia301::Frame request_;
  SdoOutcome outcome_;
};

/// What the SDO client sends and receives through: the socket before the
/// RT loop runs, the RT loop's hand-over while it does, the simulated drive
/// in tests.
class FrameLink {
 public:
  virtual ~FrameLink() = default;
  virtual bool send(const cia301::Frame& frame) = 0;
  /// Waits until a frame arrives or `deadline` passes; false on timeout or a
  /// dead link (then link_error() says why).
  virtual bool receive(cia301::Frame& frame, std::chrono::steady_clock::time_point deadline) = 0;
  virtual std::string link_error() const { return {}; }
};

/// Thrown for an exchange that did not end in ok; what() is the one-line description.
class SdoError : public std::runtime_error {
 public:
  SdoError(const std::string& what, SdoOutcome outcome)
      : std::runtime_error(what), outcome_(std::move(outcome)) {}
  const SdoOutcome& outcome() const noexcept { return outcome_; }
  bool object_missing() const noexcept {
    return outcome_.kind == SdoOutcome::Kind::aborted &&
           (outcome_.abort_code == cia301::abort_code::no_object ||
            outcome_.abort_code == cia301::abort_code::no_sub_index);
  }

 private:
  SdoOutcome outcome_;
};

class SdoClient {
 public:
  /// `stop`: the daemon's stop request; a transfer waiting for its answer
  /// gives way to it within stop_slice (aborted on the bus, StopRequested).
  SdoClient(FrameLink& link, std::uint8_t node, std::chrono::microseconds timeout, StopToken stop = {})
      : link_(link), node_(node), timeout_(timeout), stop_(std::move(stop)) {}
  /// Runs one exchange to its end (ok, abort, or timeout) and returns it.
  /// Throws StopRequested when a stop request ended the wait.
  SdoExchange run(SdoExchange exchange);
  /// Reads a value; throws SdoError.
  std::uint32_t read(cia301::ObjectAddress address);
  /// Writes a value of `size` bytes; throws SdoError.
  void write(cia301::ObjectAddress address, std::uint32_t value, std::uint8_t size);
  std::uint8_t node() const noexcept { return node_; }

 private:
  FrameLink& link_;
  std::uint8_t node_;
  std::chrono::microseconds timeout_;
  StopToken stop_;
};

}  // namespace hapticd::drivers::canopen
