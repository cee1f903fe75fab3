#include "drivers/usb_hid/usb_transport.hpp"

#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "rt/spsc_ring.hpp"

namespace hapticd::drivers::usb_hid {

namespace {

constexpr std::size_t completion_ring_capacity = 32;

TransferOutcome outcome_of(libusb_transfer_status status) noexcept {
  switch (status) {
    case LIBUSB_TRANSFER_COMPLETED:
      return TransferOutcome::completed;
    case LIBUSB_TRANSFER_NO_DEVICE:
      return TransferOutcome::no_device;
    case LIBUSB_TRANSFER_STALL:
      return TransferOutcome::stall;
    case LIBUSB_TRANSFER_OVERFLOW:
      return TransferOutcome::overflow;
    case LIBUSB_TRANSFER_TIMED_OUT:
      return TransferOutcome::timed_out;
    case LIBUSB_TRANSFER_CANCELLED:
      return TransferOutcome::cancelled;
    case LIBUSB_TRANSFER_ERROR:
      break;
  }
  return TransferOutcome::error;
}

UsbSpeed speed_of(int speed) noexcept {
  switch (speed) {
    case LIBUSB_SPEED_LOW:
      return UsbSpeed::low;
    case LIBUSB_SPEED_FULL:
      return UsbSpeed::full;
    case LIBUSB_SPEED_HIGH:
      return UsbSpeed::high;
    case LIBUSB_SPEED_SUPER:
      return UsbSpeed::super;
    case LIBUSB_SPEED_SUPER_PLUS:
      return UsbSpeed::super_plus;
    default:
      return UsbSpeed::unknown;
  }
}

std::string id_text(std::uint16_t vendor, std::uint16_t product) {
  char text[16];
  std::snprintf(text, sizeof text, "%04x:%04x", static_cast<unsigned>(vendor),
                static_cast<unsigned>(product));
  return text;
}

/// "1-2.3": the bus number, then the port chain from the root hub (the
/// kernel's sysfs name for the device, what `lsusb -t` and udev's KERNELS show).
std::string path_of(libusb_device* dev) {
  std::uint8_t ports[7];
  const int n = libusb_get_port_numbers(dev, ports, sizeof ports);
  std::string path = std::to_string(libusb_get_bus_number(dev)) + "-";
  for (int i = 0; i < n; ++i) path += (i > 0 ? "." : "") + std::to_string(ports[i]);
  return path;
}

struct Slot {
  libusb_transfer* transfer = nullptr;
  std::vector<unsigned char> buffer;
  std::atomic<bool> in_flight{false};
};

}  // namespace

struct UsbTransport::Impl {
  TransportOptions options;
  std::uint16_t vendor_id = 0, product_id = 0;
  libusb_context* ctx = nullptr;
  libusb_device_handle* handle = nullptr;
  libusb_hotplug_callback_handle hotplug{};
  bool hotplug_registered = false;
  int interface_number = -1;
  std::uint8_t in_ep = 0, out_ep = 0;
  std::vector<std::unique_ptr<Slot>> in_slots, out_slots;
  std::size_t next_out = 0;

  rt::SpscRing<InCompletion> in_ring{completion_ring_capacity};
  rt::SpscRing<TransferOutcome> out_ring{completion_ring_capacity};
  std::atomic<bool> stopping{false};
  std::atomic<int> in_flight{0};

  std::thread event_thread;
  std::atomic<bool> event_thread_stop{false};

  std::atomic<std::uint64_t> in_completions{0}, out_completions{0}, in_resubmit_failures{0}, event_errors{0},
      arrivals{0}, departures{0};

  static void LIBUSB_CALL on_in(libusb_transfer* transfer);
  static void LIBUSB_CALL on_out(libusb_transfer* transfer);
  static int LIBUSB_CALL on_hotplug(libusb_context*, libusb_device*, libusb_hotplug_event event, void* self);

  void free_slots() noexcept {
    for (auto* slots : {&in_slots, &out_slots}) {
      for (auto& slot : *slots) libusb_free_transfer(slot->transfer);
      slots->clear();
    }
  }
  void make_slots(std::vector<std::unique_ptr<Slot>>& slots, int count, std::uint8_t endpoint,
                  std::size_t size, libusb_transfer_cb_fn callback) {
    for (int i = 0; i < count; ++i) {
      auto slot = std::make_unique<Slot>();
      slot->transfer = libusb_alloc_transfer(0);
      if (slot->transfer == nullptr) throw TransportError("libusb_alloc_transfer failed (out of memory)");
      slot->buffer.assign(size, 0);
      // No libusb timeout: the session counts periods instead (a libusb
      // timeout would arm a timerfd on every submission).
      libusb_fill_interrupt_transfer(slot->transfer, handle, endpoint, slot->buffer.data(),
                                     static_cast<int>(size), callback, this, 0);
      slot->transfer->user_data = this;
      slots.push_back(std::move(slot));
    }
  }
  Slot* slot_of(const std::vector<std::unique_ptr<Slot>>& slots, libusb_transfer* transfer) noexcept {
    for (const auto& slot : slots)
      if (slot->transfer == transfer) return slot.get();
    return nullptr;
  }
  void push_in(TransferOutcome outcome, const libusb_transfer* transfer) noexcept {
    InCompletion c;
    c.outcome = outcome;
    const auto length = static_cast<std::size_t>(std::max(transfer->actual_length, 0));
    c.length = static_cast<std::uint8_t>(std::min(length, max_report_size));
    std::memcpy(c.bytes, transfer->buffer, c.length);
    static_cast<void>(in_ring.try_push(c));  // a full ring counts its own drop
  }
  void handle_events(double timeout_s) noexcept {
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(timeout_s);
    tv.tv_usec = static_cast<suseconds_t>((timeout_s - static_cast<double>(tv.tv_sec)) * 1e6);
    if (libusb_handle_events_timeout_completed(ctx, &tv, nullptr) < 0)
      event_errors.fetch_add(1, std::memory_order_relaxed);
  }
  void event_loop() noexcept {
    while (!event_thread_stop.load(std::memory_order_acquire)) handle_events(0.1);
  }
};

void LIBUSB_CALL UsbTransport::Impl::on_in(libusb_transfer* transfer) {
  auto* self = static_cast<Impl*>(transfer->user_data);
  const TransferOutcome outcome = outcome_of(transfer->status);
  self->in_completions.fetch_add(1, std::memory_order_relaxed);
  self->push_in(outcome, transfer);
  Slot* slot = self->slot_of(self->in_slots, transfer);
  const bool resubmit = !self->stopping.load(std::memory_order_acquire) &&
                        (outcome == TransferOutcome::completed || outcome == TransferOutcome::error ||
                         outcome == TransferOutcome::overflow || outcome == TransferOutcome::timed_out);
  // Resubmit at once: with >= 2 IN transfers queued the host controller
  // always has one to poll the endpoint with while this one is handled.
  if (resubmit) {
    const int r = libusb_submit_transfer(transfer);
    if (r == 0) return;
    self->in_resubmit_failures.fetch_add(1, std::memory_order_relaxed);
    InCompletion c;
    c.outcome = r == LIBUSB_ERROR_NO_DEVICE ? TransferOutcome::no_device : TransferOutcome::error;
    static_cast<void>(self->in_ring.try_push(c));
  }
  if (slot != nullptr) slot->in_flight.store(false, std::memory_order_release);
  self->in_flight.fetch_sub(1, std::memory_order_acq_rel);
}

void LIBUSB_CALL UsbTransport::Impl::on_out(libusb_transfer* transfer) {
  auto* self = static_cast<Impl*>(transfer->user_data);
  self->out_completions.fetch_add(1, std::memory_order_relaxed);
  static_cast<void>(self->out_ring.try_push(outcome_of(transfer->status)));
  if (Slot* slot = self->slot_of(self->out_slots, transfer))
    slot->in_flight.store(false, std::memory_order_release);
  self->in_flight.fetch_sub(1, std::memory_order_acq_rel);
}

int LIBUSB_CALL UsbTransport::Impl::on_hotplug(libusb_context*, libusb_device*, libusb_hotplug_event event,
                                               void* user) {
  auto* self = static_cast<Impl*>(user);
  if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED)
    self->arrivals.fetch_add(1, std::memory_order_relaxed);
  else
    self->departures.fetch_add(1, std::memory_order_relaxed);
  return 0;  // stay registered
}

namespace {

/// Claims the interface (libusb detaches a kernel driver first: auto-detach),
/// reads its interrupt endpoints and the bus speed, makes the transfers.
OpenedBoard claim_and_describe(UsbTransport::Impl& s, const UsbSelector& selector, OpenedBoard board) {
  libusb_device* dev = libusb_get_device(s.handle);
  const int iface = selector.interface_number;
  libusb_set_auto_detach_kernel_driver(s.handle, 1);
  board.detached_kernel_driver = libusb_kernel_driver_active(s.handle, iface) == 1;
  const int r = libusb_claim_interface(s.handle, iface);
  if (r != 0)
    throw TransportError("interface " + std::to_string(iface) + " of the board at " + board.path +
                             " cannot be claimed: " + libusb_error_name(r) +
                             (r == LIBUSB_ERROR_BUSY ? " (another program holds it)" : ""),
                         "interface");
  libusb_config_descriptor* config = nullptr;
  if (libusb_get_active_config_descriptor(dev, &config) != 0 || config == nullptr)
    throw TransportError("the board at " + board.path + " has no active configuration");
  const UsbSpeed speed = speed_of(libusb_get_device_speed(dev));
  bool have_in = false, have_out = false;
  for (int i = 0; i < config->bNumInterfaces; ++i) {
    const libusb_interface& interface = config->interface[i];
    if (interface.num_altsetting < 1 || interface.altsetting[0].bInterfaceNumber != iface) continue;
    const libusb_interface_descriptor& alt = interface.altsetting[0];
    for (int e = 0; e < alt.bNumEndpoints; ++e) {
      const libusb_endpoint_descriptor& ep = alt.endpoint[e];
      if ((ep.bmAttributes & 0x03U) != LIBUSB_TRANSFER_TYPE_INTERRUPT) continue;
      const bool in = (ep.bEndpointAddress & LIBUSB_ENDPOINT_IN) != 0;
      const std::uint8_t wanted = in ? selector.in_endpoint : selector.out_endpoint;
      if ((in ? have_in : have_out) || (wanted != 0 && wanted != ep.bEndpointAddress)) continue;
      EndpointInfo info;
      info.address = ep.bEndpointAddress;
      info.max_packet_size = static_cast<std::uint16_t>(ep.wMaxPacketSize & 0x7FFU);
      info.extra_transactions = static_cast<std::uint8_t>((ep.wMaxPacketSize >> 11U) & 0x3U);
      info.b_interval = ep.bInterval;
      info.speed = speed;
      (in ? board.in : board.out) = info;
      (in ? have_in : have_out) = true;
    }
  }
  libusb_free_config_descriptor(config);
  if (!have_in || !have_out)
    throw TransportError(
        "interface " + std::to_string(iface) + " of the board at " + board.path + " has no " +
            (have_in ? "interrupt OUT" : "interrupt IN") + " endpoint" +
            ((have_in ? selector.out_endpoint : selector.in_endpoint) != 0 ? " at the address given" : ""),
        have_in ? "out_endpoint" : "in_endpoint");
  s.in_ep = board.in.address;
  s.out_ep = board.out.address;
  s.free_slots();
  s.make_slots(s.in_slots, s.options.in_transfers, s.in_ep,
               std::max<std::size_t>(bytes_per_interval(board.in), 1), &UsbTransport::Impl::on_in);
  s.make_slots(s.out_slots, s.options.out_transfers, s.out_ep, s.options.out_size,
               &UsbTransport::Impl::on_out);
  s.next_out = 0;
  char ids[64];
  std::snprintf(ids, sizeof ids, "%s", id_text(selector.vendor_id, selector.product_id).c_str());
  board.description = std::string(ids) + (board.serial.empty() ? "" : " serial " + board.serial) + " at " +
                      board.path + ", " + std::string(to_string(speed));
  return board;
}

}  // namespace

UsbTransport::UsbTransport(const TransportOptions& options, std::uint16_t vendor_id, std::uint16_t product_id)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.options = options;
  s.vendor_id = vendor_id;
  s.product_id = product_id;
  if (options.in_transfers < 2)
    throw TransportError("in_transfers = " + std::to_string(options.in_transfers) +
                             ": at least 2 IN transfers must stay queued (the host polls with one while the "
                             "driver handles the other)",
                         "in_transfers");
  const int r = libusb_init(&s.ctx);
  if (r != 0) throw TransportError(std::string("libusb_init failed: ") + libusb_error_name(r));
  if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0) {
    const int h = libusb_hotplug_register_callback(
        s.ctx, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT,
        LIBUSB_HOTPLUG_NO_FLAGS, vendor_id, product_id, LIBUSB_HOTPLUG_MATCH_ANY, &Impl::on_hotplug, &s,
        &s.hotplug);
    s.hotplug_registered = h == LIBUSB_SUCCESS;
  }
}

UsbTransport::~UsbTransport() {
  stop();
  close();
  Impl& s = *impl_;
  s.free_slots();
  if (s.hotplug_registered) libusb_hotplug_deregister_callback(s.ctx, s.hotplug);
  libusb_exit(s.ctx);
}

OpenedBoard UsbTransport::open(const UsbSelector& selector) {
  Impl& s = *impl_;
  if (s.handle != nullptr) close();
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(s.ctx, &list);
  if (n < 0)
    throw TransportError(std::string("cannot list USB devices: ") + libusb_error_name(static_cast<int>(n)));
  const std::string wanted = id_text(selector.vendor_id, selector.product_id);
  std::string seen, open_error;
  libusb_device_handle* chosen = nullptr;
  OpenedBoard board;
  for (ssize_t i = 0; i < n && chosen == nullptr; ++i) {
    libusb_device* dev = list[i];
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(dev, &desc) != 0 || desc.idVendor != selector.vendor_id ||
        desc.idProduct != selector.product_id)
      continue;
    const std::string path = path_of(dev);
    libusb_device_handle* h = nullptr;
    const int r = libusb_open(dev, &h);
    if (r != 0) {
      open_error =
          wanted + " at " + path + " cannot be opened: " + libusb_error_name(r) +
          (r == LIBUSB_ERROR_ACCESS ? " (no permission on its /dev/bus/usb node: install "
                                      "config/70-hapticd-usb-hid.rules, see drivers/usb_hid/README.md)"
                                    : "");
      continue;
    }
    char serial[128] = "";
    if (desc.iSerialNumber != 0 &&
        libusb_get_string_descriptor_ascii(h, desc.iSerialNumber, reinterpret_cast<unsigned char*>(serial),
                                           sizeof serial) < 0)
      serial[0] = '\0';
    seen += (seen.empty() ? "" : ", ") + std::string("serial \"") + serial + "\" at " + path;
    if ((!selector.path.empty() && path != selector.path) ||
        (!selector.serial.empty() && selector.serial != serial)) {
      libusb_close(h);
      continue;
    }
    chosen = h;
    board.path = path;
    board.serial = serial;
  }
  libusb_free_device_list(list, 1);
  if (chosen == nullptr) {
    if (!open_error.empty()) throw TransportError(open_error, "vendor_id");
    if (seen.empty())
      throw TransportError("no USB device " + wanted + " on the bus (is the board plugged in? `lsusb -d " +
                               wanted + "` lists it)",
                           "vendor_id");
    const std::string key = !selector.serial.empty() ? "serial" : "path";
    throw TransportError("no USB device " + wanted +
                             (selector.serial.empty() ? "" : " serial \"" + selector.serial + "\"") +
                             (selector.path.empty() ? "" : " at " + selector.path) + "; found: " + seen,
                         key);
  }
  s.handle = chosen;
  s.interface_number = selector.interface_number;
  try {
    board = claim_and_describe(s, selector, board);
  } catch (...) {
    libusb_close(s.handle);
    s.handle = nullptr;
    throw;
  }
  return board;
}

void UsbTransport::start() {
  Impl& s = *impl_;
  if (s.handle == nullptr) throw std::logic_error("UsbTransport::start before open");
  s.stopping.store(false, std::memory_order_release);
  for (auto& slot : s.in_slots) {
    if (slot->in_flight.load(std::memory_order_acquire)) continue;
    slot->transfer->dev_handle = s.handle;
    slot->in_flight.store(true, std::memory_order_release);
    s.in_flight.fetch_add(1, std::memory_order_acq_rel);
    const int r = libusb_submit_transfer(slot->transfer);
    if (r != 0) {
      slot->in_flight.store(false, std::memory_order_release);
      s.in_flight.fetch_sub(1, std::memory_order_acq_rel);
      throw TransportError(std::string("cannot queue IN transfers on the board: ") + libusb_error_name(r));
    }
  }
  if (s.options.events == EventHandling::thread && !s.event_thread.joinable()) {
    s.event_thread_stop.store(false, std::memory_order_release);
    s.event_thread = std::thread([&s] { s.event_loop(); });
  }
}

void UsbTransport::stop() noexcept {
  Impl& s = *impl_;
  s.stopping.store(true, std::memory_order_release);
  for (auto* slots : {&s.in_slots, &s.out_slots})
    for (auto& slot : *slots)
      if (slot->in_flight.load(std::memory_order_acquire))
        static_cast<void>(libusb_cancel_transfer(slot->transfer));
  // Cancelled transfers come back through the event handler; a transfer
  // must not be reused or freed before it has.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (s.in_flight.load(std::memory_order_acquire) > 0 && std::chrono::steady_clock::now() < give_up) {
    if (s.event_thread.joinable())
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    else
      s.handle_events(0.01);
  }
  if (s.event_thread.joinable()) {
    s.event_thread_stop.store(true, std::memory_order_release);
    libusb_interrupt_event_handler(s.ctx);
    s.event_thread.join();
  }
}

void UsbTransport::close() noexcept {
  Impl& s = *impl_;
  if (s.handle == nullptr) return;
  // Releasing with auto-detach on lets libusb give the interface back to the
  // kernel driver it took it from.
  static_cast<void>(libusb_release_interface(s.handle, s.interface_number));
  libusb_close(s.handle);
  s.handle = nullptr;
}

bool UsbTransport::is_open() const noexcept { return impl_->handle != nullptr; }

std::string UsbTransport::clear_halt(std::uint8_t endpoint) {
  Impl& s = *impl_;
  if (s.handle == nullptr) return "the board is not open";
  const int r = libusb_clear_halt(s.handle, endpoint);
  if (r == 0) return {};
  char text[96];
  std::snprintf(text, sizeof text, "CLEAR_FEATURE(ENDPOINT_HALT) on 0x%02x failed: %s",
                static_cast<unsigned>(endpoint), libusb_error_name(r));
  return text;
}

bool UsbTransport::present(const UsbSelector& selector) {
  Impl& s = *impl_;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(s.ctx, &list);
  bool found = false;
  for (ssize_t i = 0; i < n && !found; ++i) {
    libusb_device_descriptor desc{};
    found = libusb_get_device_descriptor(list[i], &desc) == 0 && desc.idVendor == selector.vendor_id &&
            desc.idProduct == selector.product_id &&
            (selector.path.empty() || path_of(list[i]) == selector.path);
  }
  if (n >= 0) libusb_free_device_list(list, 1);
  return found;
}

bool UsbTransport::wait_for_in(double timeout_s, const StopToken& stop) {
  Impl& s = *impl_;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (s.in_ring.empty()) {
    if (std::chrono::steady_clock::now() >= give_up || stop.stop_requested()) return false;
    if (s.event_thread.joinable())
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    else
      s.handle_events(0.005);
  }
  return true;
}

void UsbTransport::poll() noexcept {
  Impl& s = *impl_;
  if (s.options.events != EventHandling::loop) return;
  timeval zero{};
  if (libusb_handle_events_timeout_completed(s.ctx, &zero, nullptr) < 0)
    s.event_errors.fetch_add(1, std::memory_order_relaxed);
}

bool UsbTransport::pop_in(InCompletion& out) noexcept { return impl_->in_ring.try_pop(out); }

bool UsbTransport::pop_out(TransferOutcome& out) noexcept { return impl_->out_ring.try_pop(out); }

SubmitResult UsbTransport::submit_out(std::span<const std::uint8_t> report) noexcept {
  Impl& s = *impl_;
  // Closed (the board was unplugged and not re-opened yet): the transfers
  // still name the old handle, which libusb has freed.
  if (s.handle == nullptr) return SubmitResult::no_device;
  const std::size_t n = s.out_slots.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t index = (s.next_out + k) % n;
    Slot& slot = *s.out_slots[index];
    if (slot.in_flight.load(std::memory_order_acquire)) continue;
    const std::size_t length = std::min(report.size(), slot.buffer.size());
    std::memcpy(slot.buffer.data(), report.data(), length);
    slot.transfer->length = static_cast<int>(length);
    slot.in_flight.store(true, std::memory_order_release);
    s.in_flight.fetch_add(1, std::memory_order_acq_rel);
    const int r = libusb_submit_transfer(slot.transfer);
    if (r != 0) {
      slot.in_flight.store(false, std::memory_order_release);
      s.in_flight.fetch_sub(1, std::memory_order_acq_rel);
      return r == LIBUSB_ERROR_NO_DEVICE ? SubmitResult::no_device : SubmitResult::error;
    }
    s.next_out = (index + 1) % n;
    return SubmitResult::queued;
  }
  return SubmitResult::busy;
}

TransportCounters UsbTransport::counters() const noexcept {
  const Impl& s = *impl_;
  TransportCounters c;
  c.in_completions = s.in_completions.load(std::memory_order_relaxed);
  c.out_completions = s.out_completions.load(std::memory_order_relaxed);
  c.in_resubmit_failures = s.in_resubmit_failures.load(std::memory_order_relaxed);
  c.event_errors = s.event_errors.load(std::memory_order_relaxed);
  c.ring_overflows = s.in_ring.dropped() + s.out_ring.dropped();
  c.hotplug_arrivals = s.arrivals.load(std::memory_order_relaxed);
  c.hotplug_departures = s.departures.load(std::memory_order_relaxed);
  return c;
}

std::uint8_t UsbTransport::in_endpoint() const noexcept { return impl_->in_ep; }
std::uint8_t UsbTransport::out_endpoint() const noexcept { return impl_->out_ep; }

}  // namespace hapticd::drivers::usb_hid
