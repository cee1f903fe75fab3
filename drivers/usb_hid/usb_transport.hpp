#pragma once
/// \file
/// The one file of the usb-hid driver that makes system calls: libusb-1.0.
/// Finds the board (VID:PID, optionally serial number and bus/port path),
/// claims its interface with automatic kernel-driver detach, reads the
/// interrupt endpoint descriptors and the bus speed, and runs asynchronous
/// interrupt transfers: `in_transfers` (>= 2) IN transfers always queued so
/// the host controller polls every interval, and one OUT transfer per
/// period from a pool of `out_transfers`. Every transfer and buffer is made
/// at open(); the per-period calls allocate nothing themselves (libusb's
/// Linux backend callocs one URB struct per submission and frees it at
/// reap: README.md "Allocation").
///
/// Events (README.md "Event handling"): `loop` handles libusb events from
/// the RT thread with a zero timeout in poll(); `thread` runs them on an
/// event thread. Either way completions reach the RT thread through
/// lock-free rings (rt/spsc_ring.hpp).
///
/// Threads: open/start/stop/close/clear_halt/present are non-RT and must
/// not overlap the RT calls (poll/pop_in/pop_out/submit_out); the device
/// parks its RT side around them.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

#include "drivers/stop_request.hpp"
#include "drivers/usb_hid/host_session.hpp"
#include "drivers/usb_hid/link_budget.hpp"
#include "drivers/usb_hid/report_codec.hpp"

namespace hapticd::drivers::usb_hid {

enum class EventHandling : std::uint8_t { loop, thread };

struct UsbSelector {
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  std::string serial;  ///< "" = any
  std::string path;    ///< "" = any; "1-2.3": bus 1, port 2, then port 3 of the hub there
  int interface_number = 0;
  std::uint8_t in_endpoint = 0;   ///< 0: the interface's first interrupt IN endpoint
  std::uint8_t out_endpoint = 0;  ///< 0: the interface's first interrupt OUT endpoint
};

struct TransportOptions {
  EventHandling events = EventHandling::loop;
  int in_transfers = 2;
  int out_transfers = 4;
  std::size_t out_size = 8;  ///< bytes per OUT report
};

/// What open() found.
struct OpenedBoard {
  std::string path;         ///< "1-2"
  std::string serial;       ///< "" if the board has none
  std::string description;  ///< "1209:0001 serial SIM0001 at 1-2, full speed (12 Mbit/s)"
  EndpointInfo in, out;
  bool detached_kernel_driver = false;  ///< a kernel driver (usbhid) held the interface
};

/// A failure to find, open or claim the board. `key` names the config key to blame.
class TransportError : public std::runtime_error {
 public:
  TransportError(const std::string& message, std::string key = {})
      : std::runtime_error(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// One IN transfer's completion, copied out of the transfer's buffer.
struct InCompletion {
  TransferOutcome outcome = TransferOutcome::completed;
  std::uint8_t length = 0;
  std::uint8_t bytes[max_report_size]{};
};

enum class SubmitResult : std::uint8_t {
  queued,
  busy,       ///< every OUT transfer still in flight
  no_device,  ///< LIBUSB_ERROR_NO_DEVICE: unplugged
  error,      ///< any other libusb error
};

struct TransportCounters {
  std::uint64_t in_completions = 0;
  std::uint64_t out_completions = 0;
  std::uint64_t in_resubmit_failures = 0;
  std::uint64_t event_errors = 0;      ///< libusb_handle_events_* returned an error
  std::uint64_t ring_overflows = 0;    ///< completions dropped because the RT side did not drain
  std::uint64_t hotplug_arrivals = 0;  ///< matching boards plugged in (hotplug callback)
  std::uint64_t hotplug_departures = 0;
};

class UsbTransport {
 public:
  /// libusb_init, hotplug registration for the VID:PID. Throws TransportError.
  UsbTransport(const TransportOptions& options, std::uint16_t vendor_id, std::uint16_t product_id);
  ~UsbTransport();
  UsbTransport(const UsbTransport&) = delete;
  UsbTransport& operator=(const UsbTransport&) = delete;

  // ---- non-RT ----
  /// Finds, opens and claims the board; makes the transfers. Throws TransportError.
  OpenedBoard open(const UsbSelector& selector);
  /// Submits the IN transfers (and starts the event thread in thread mode).
  void start();
  /// Cancels every transfer and waits (bounded, 1 s) for them to come back.
  void stop() noexcept;
  /// Releases the interface (libusb re-attaches the kernel driver) and closes.
  void close() noexcept;
  bool is_open() const noexcept;
  /// CLEAR_FEATURE(ENDPOINT_HALT) on the endpoint; "" or the error in words.
  std::string clear_halt(std::uint8_t endpoint);
  /// Is a board matching the selector on the bus now (after a re-plug)?
  bool present(const UsbSelector& selector);
  /// Handles events for up to `timeout_s` until an IN completion is queued
  /// (configure's wait for the first report); false also when `stop` was
  /// requested meanwhile. Non-RT.
  bool wait_for_in(double timeout_s, const StopToken& stop = {});

  // ---- RT ----
  /// loop mode: libusb_handle_events_timeout_completed with a zero timeout
  /// (callbacks run here); thread mode: nothing.
  void poll() noexcept;
  bool pop_in(InCompletion& out) noexcept;
  bool pop_out(TransferOutcome& out) noexcept;
  SubmitResult submit_out(std::span<const std::uint8_t> report) noexcept;

  TransportCounters counters() const noexcept;
  std::uint8_t in_endpoint() const noexcept;
  std::uint8_t out_endpoint() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace hapticd::drivers::usb_hid
