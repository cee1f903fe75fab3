#pragma once
/// \file
/// Test helper (in the spirit of libgpiod's gpiosim): puts a SimulatedBoard
/// on an emulated USB bus with umockdev, so the driver runs libusb's real
/// Linux code path against it. The testbed holds the board's sysfs node
/// (descriptors, speed, busnum/devnum) and /dev/bus/usb/BBB/DDD; an ioctl
/// handler (umockdev_testbed_attach_ioctl) answers the usbdevfs requests
/// libusb makes: capabilities, claim with kernel-driver disconnect, release
/// and re-attach, submit / reap / discard URB, clear halt, and the control
/// transfers for string descriptors. The model is libusb's own
/// tests/umockdev.c.
///
/// The process that creates it owns the testbed and the handler thread. libusb
/// sees the board either in this process (which must run with
/// libumockdev-preload: link it with --no-as-needed before libc, or start
/// under LD_PRELOAD) or in a child started with
/// LD_PRELOAD=libumockdev-preload.so.0 and UMOCKDEV_DIR=root_dir().
///
/// Emulated ioctls are a round trip to the handler's thread: nothing timed
/// here means anything about a real bus.

#include <cstdint>
#include <memory>
#include <string>

#include "drivers/usb_hid/link_budget.hpp"
#include "sim/usb_hid/simulated_board.hpp"

namespace hapticd::drivers::usb_hid::sim {

/// What the emulated board says about itself (descriptors and sysfs).
struct EmulatedUsbIdentity {
  std::uint16_t vendor_id = 0x1209;   ///< pid.codes (open-source hardware vendor ID)
  std::uint16_t product_id = 0x0001;  ///< pid.codes test PID
  std::string manufacturer = "hapticd";
  std::string product = "simulated encoder/motor board";
  std::string serial = "SIM0001";
  UsbSpeed speed = UsbSpeed::full;
  std::uint8_t interface_number = 0;
  std::uint8_t in_endpoint = 0x81;
  std::uint8_t out_endpoint = 0x01;
  std::uint16_t max_packet_size = 64;
  std::uint8_t in_interval = 1;  ///< bInterval as written in the descriptor
  std::uint8_t out_interval = 1;
  std::uint8_t bus = 1;
  std::string ports = "2";  ///< port chain below the root hub: sysfs name "<bus>-<ports>"
  std::uint8_t first_address = 2;
  bool kernel_driver_bound = true;  ///< usbhid holds the interface at plug-in: the driver must detach it
};

struct UsbTestbedCounters {
  std::uint64_t in_submitted = 0;
  std::uint64_t out_submitted = 0;
  std::uint64_t reaped = 0;
  std::uint64_t discarded = 0;
  std::uint64_t control_transfers = 0;
  std::uint64_t claims = 0;
  std::uint64_t kernel_driver_detaches = 0;
  std::uint64_t kernel_driver_attaches = 0;
  std::uint64_t releases = 0;
  std::uint64_t clear_halts = 0;
  std::uint64_t no_device_replies = 0;  ///< ENODEV answers after an unplug
  std::uint64_t unhandled_ioctls = 0;   ///< answered ENOTTY (see last_unhandled_request)
  unsigned long last_unhandled_request = 0;
  std::uint64_t in_flight_in = 0;  ///< IN URBs waiting for a report now
  bool claimed = false;
  bool kernel_driver_bound = false;
  bool plugged = false;
};

class UmockdevUsbBoard {
 public:
  /// Creates the testbed (and sets UMOCKDEV_DIR in this process) and plugs
  /// the board in. Throws std::runtime_error if umockdev refuses.
  UmockdevUsbBoard(const EmulatedUsbIdentity& identity, SimulatedBoard& board);
  ~UmockdevUsbBoard();
  UmockdevUsbBoard(const UmockdevUsbBoard&) = delete;
  UmockdevUsbBoard& operator=(const UmockdevUsbBoard&) = delete;

  /// The testbed root: UMOCKDEV_DIR for a child process.
  std::string root_dir() const;
  /// "/dev/bus/usb/001/002" (the current address).
  std::string devnode() const;
  /// "1-2": bus and port chain, as the driver's `path` key takes it.
  std::string port_path() const;

  /// Unplug: URBs in flight complete with -ESHUTDOWN, every later request
  /// on the old node gets ENODEV, and a remove uevent goes out.
  void unplug();
  /// Plug in again (the board powers up afresh) at the next device address,
  /// with an add uevent.
  void replug();
  /// The endpoint halts: URBs on it complete with -EPIPE until CLEAR_HALT.
  void stall(std::uint8_t endpoint);

  UsbTestbedCounters counters() const;
  SimulatedBoard& board() noexcept;

  /// True when libumockdev-preload is active in this process.
  static bool preload_active();

  struct State;  // the handler's state (umockdev_board.cpp)

 private:
  std::unique_ptr<State> state_;
};

}  // namespace hapticd::drivers::usb_hid::sim
