#include "sim/usb_hid/umockdev_board.hpp"

#include <dlfcn.h>
#include <linux/ioctl.h>
#include <linux/usbdevice_fs.h>
#include <umockdev.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

namespace hapticd::drivers::usb_hid::sim {

namespace {

/// A URB the handler holds: the client's addresses and what to put there at reap.
struct HeldUrb {
  gulong client_addr = 0;
  std::uint8_t type = 0;
  std::uint8_t endpoint = 0;
  int buffer_length = 0;
  int status = 0;
  std::vector<std::uint8_t> data;  ///< bytes for the client's buffer at reap (IN, control)
  std::size_t data_offset = 0;     ///< control transfers: data follow the 8-byte setup
};

struct ClientUrbs {
  std::string devnode;
  std::deque<HeldUrb> waiting_in;  ///< IN URBs the board has not answered yet (host polls, board NAKs)
  std::deque<HeldUrb> completed;   ///< ready for REAPURB
};

std::string hex(std::span<const std::uint8_t> bytes) {
  std::string out;
  char two[3];
  for (const std::uint8_t b : bytes) {
    std::snprintf(two, sizeof two, "%02x", static_cast<unsigned>(b));
    out += two;
  }
  return out;
}

void put16(std::vector<std::uint8_t>& v, unsigned value) {
  v.push_back(static_cast<std::uint8_t>(value & 0xFFU));
  v.push_back(static_cast<std::uint8_t>((value >> 8) & 0xFFU));
}

/// HID report descriptor of the board: vendor page, one 8-bit array per
/// direction (README.md "Descriptors").
std::vector<std::uint8_t> report_descriptor(std::size_t in_size, std::size_t out_size) {
  return {0x06, 0x00,
          0xFF,        // Usage Page (Vendor 0xFF00)
          0x09, 0x01,  // Usage 1
          0xA1, 0x01,  // Collection (Application)
          0x09, 0x02,
          0x15, 0x00,
          0x26, 0xFF,
          0x00, 0x75,
          0x08,  // Usage 2, logical 0..255, 8 bits
          0x95, static_cast<std::uint8_t>(in_size),
          0x81, 0x02,  // Report Count, Input (Data,Var,Abs)
          0x09, 0x03,
          0x95, static_cast<std::uint8_t>(out_size),
          0x91, 0x02,  // Usage 3, Output
          0xC0};
}

/// Device + configuration descriptors as sysfs "descriptors" holds them (bus-endian).
std::vector<std::uint8_t> board_descriptors(const EmulatedUsbIdentity& id, std::size_t hid_length) {
  std::vector<std::uint8_t> d = {18, 1};
  put16(d, 0x0200);                  // bcdUSB 2.00
  d.insert(d.end(), {0, 0, 0, 64});  // class from interface; EP0 64 bytes
  put16(d, id.vendor_id);
  put16(d, id.product_id);
  put16(d, 0x0100);                 // bcdDevice
  d.insert(d.end(), {1, 2, 3, 1});  // iManufacturer, iProduct, iSerialNumber, one configuration
  const std::size_t total = 9 + 9 + 9 + 7 + 7;
  d.insert(d.end(), {9, 2});
  put16(d, total);
  d.insert(d.end(), {1, 1, 0, 0x80, 50});  // one interface, value 1, bus powered, 100 mA
  d.insert(d.end(), {9, 4, id.interface_number, 0, 2, 0x03, 0, 0, 0});  // HID, no boot protocol
  d.insert(d.end(), {9, 0x21, 0x11, 0x01, 0, 1, 0x22});                 // HID 1.11, one report descriptor
  put16(d, static_cast<unsigned>(hid_length));
  d.insert(d.end(), {7, 5, id.in_endpoint, 0x03});
  put16(d, id.max_packet_size);
  d.push_back(id.in_interval);
  d.insert(d.end(), {7, 5, id.out_endpoint, 0x03});
  put16(d, id.max_packet_size);
  d.push_back(id.out_interval);
  return d;
}

/// The root hub of the emulated bus (Linux Foundation 1d6b:0002), so libusb
/// finds the board's parent and its port numbers.
const char* root_hub_descriptors =
    "12010002090001406b1d020006060302010109021900010100e0000904000001090000000705810304000c";

const char* speed_attribute(UsbSpeed speed) {
  switch (speed) {
    case UsbSpeed::low:
      return "1.5";
    case UsbSpeed::full:
      return "12";
    case UsbSpeed::high:
      return "480";
    case UsbSpeed::super:
      return "5000";
    case UsbSpeed::super_plus:
      return "10000";
    case UsbSpeed::unknown:
      break;
  }
  return "12";
}

std::vector<std::uint8_t> string_descriptor(const std::string& text) {
  std::vector<std::uint8_t> d = {static_cast<std::uint8_t>(2 + 2 * text.size()), 3};
  for (const char c : text) put16(d, static_cast<unsigned char>(c));  // ASCII -> UTF-16LE
  return d;
}

}  // namespace

struct UmockdevUsbBoard::State {
  EmulatedUsbIdentity id;
  SimulatedBoard& board;
  UMockdevTestbed* testbed = nullptr;
  UMockdevIoctlBase* handler = nullptr;

  mutable std::mutex mutex;
  std::map<UMockdevIoctlClient*, ClientUrbs> clients;
  std::string current_devnode;  // "" while unplugged
  std::uint8_t address = 0;
  std::set<std::uint8_t> halted;
  UsbTestbedCounters counters;

  State(const EmulatedUsbIdentity& identity, SimulatedBoard& b) : id(identity), board(b) {}

  std::string sysfs_path() const { return "/sys/devices/usb" + std::to_string(id.bus) + "/" + port_name(); }
  std::string port_name() const { return std::to_string(id.bus) + "-" + id.ports; }
  std::string node_for(std::uint8_t addr) const {
    char path[40];
    std::snprintf(path, sizeof path, "/dev/bus/usb/%03u/%03u", static_cast<unsigned>(id.bus),
                  static_cast<unsigned>(addr));
    return path;
  }

  void add_root_hub() {
    char text[1024];
    std::snprintf(text, sizeof text,
                  "P: /devices/usb%u\nN: bus/usb/%03u/001\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\n"
                  "E: DRIVER=usb\nE: BUSNUM=%03u\nE: DEVNUM=001\nE: DEVNAME=/dev/bus/usb/%03u/001\n"
                  "A: busnum=%u\\n\nA: devnum=1\\n\nA: bConfigurationValue=1\\n\nA: speed=480\\n\n"
                  "H: descriptors=%s\n",
                  static_cast<unsigned>(id.bus), static_cast<unsigned>(id.bus), static_cast<unsigned>(id.bus),
                  static_cast<unsigned>(id.bus), static_cast<unsigned>(id.bus), root_hub_descriptors);
    add_from_string(text);
  }

  void add_board() {
    const std::vector<std::uint8_t> hid = report_descriptor(board.in_report_size(), board.out_report_size());
    const std::vector<std::uint8_t> descriptors = board_descriptors(id, hid.size());
    char head[1024];
    std::snprintf(head, sizeof head,
                  "P: %s\nN: bus/usb/%03u/%03u\nE: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\nE: DRIVER=usb\n"
                  "E: BUSNUM=%03u\nE: DEVNUM=%03u\nE: DEVNAME=%s\nE: PRODUCT=%x/%x/100\n"
                  "A: busnum=%u\\n\nA: devnum=%u\\n\nA: bConfigurationValue=1\\n\nA: speed=%s\\n\n"
                  "A: idVendor=%04x\\n\nA: idProduct=%04x\\n\n",
                  sysfs_path().substr(4).c_str(), static_cast<unsigned>(id.bus),
                  static_cast<unsigned>(address), static_cast<unsigned>(id.bus),
                  static_cast<unsigned>(address), node_for(address).c_str(),
                  static_cast<unsigned>(id.vendor_id), static_cast<unsigned>(id.product_id),
                  static_cast<unsigned>(id.bus), static_cast<unsigned>(address), speed_attribute(id.speed),
                  static_cast<unsigned>(id.vendor_id), static_cast<unsigned>(id.product_id));
    add_from_string(std::string(head) + "A: serial=" + id.serial + "\\n\nA: manufacturer=" + id.manufacturer +
                    "\\n\nA: product=" + id.product + "\\n\nH: descriptors=" + hex(descriptors) + "\n");
  }

  void add_from_string(const std::string& text) {
    GError* error = nullptr;
    if (!umockdev_testbed_add_from_string(testbed, text.c_str(), &error)) {
      const std::string message = error != nullptr ? error->message : "unknown error";
      if (error != nullptr) g_error_free(error);
      throw std::runtime_error("umockdev refused the emulated USB device: " + message);
    }
  }

  void plug_locked_parts() {
    current_devnode = node_for(address);
    halted.clear();
    counters.claimed = false;
    counters.kernel_driver_bound = id.kernel_driver_bound;
    counters.plugged = true;
  }

  // ---- the ioctl handler (umockdev's worker thread) ----

  static gboolean on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    return static_cast<State*>(self)->handle(client);
  }
  static void on_connected(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    auto* state = static_cast<State*>(self);
    const std::lock_guard lock(state->mutex);
    state->clients[client] = ClientUrbs{umockdev_ioctl_client_get_devnode(client), {}, {}};
  }

  gboolean handle(UMockdevIoctlClient* client) {
    const std::lock_guard lock(mutex);
    ClientUrbs& urbs = clients[client];
    if (urbs.devnode.empty()) urbs.devnode = umockdev_ioctl_client_get_devnode(client);
    const bool gone = urbs.devnode != current_devnode;
    const unsigned long request = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);

    if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY)
      return reap(client, urbs, arg, gone);
    if (gone) return fail(client, ENODEV, true);
    switch (request) {
      case USBDEVFS_GET_CAPABILITIES: {
        UMockdevIoctlData* caps = umockdev_ioctl_data_resolve(arg, 0, sizeof(std::uint32_t), nullptr);
        const std::uint32_t value = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                                    USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
        std::memcpy(caps->data, &value, sizeof value);
        g_object_unref(caps);
        return succeed(client);
      }
      case USBDEVFS_GETDRIVER:
        return get_driver(client, arg);
      case USBDEVFS_DISCONNECT_CLAIM:
        return disconnect_claim(client, arg);
      case USBDEVFS_CLAIMINTERFACE:
        return claim(client, arg);
      case USBDEVFS_RELEASEINTERFACE:
        ++counters.releases;
        counters.claimed = false;
        return succeed(client);
      case USBDEVFS_IOCTL:
        return driver_ioctl(client, arg);
      case USBDEVFS_CLEAR_HALT: {
        UMockdevIoctlData* ep = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned int), nullptr);
        unsigned int endpoint = 0;
        std::memcpy(&endpoint, ep->data, sizeof endpoint);
        g_object_unref(ep);
        halted.erase(static_cast<std::uint8_t>(endpoint));
        ++counters.clear_halts;
        return succeed(client);
      }
      case USBDEVFS_SUBMITURB:
        return submit(client, urbs, arg);
      case USBDEVFS_DISCARDURB:
        return discard(client, urbs, arg);
      default:
        ++counters.unhandled_ioctls;
        counters.last_unhandled_request = request;
        return fail(client, ENOTTY, false);
    }
  }

  gboolean succeed(UMockdevIoctlClient* client) {
    umockdev_ioctl_client_complete(client, 0, 0);
    return TRUE;
  }
  gboolean fail(UMockdevIoctlClient* client, int error, bool no_device) {
    if (no_device) ++counters.no_device_replies;
    umockdev_ioctl_client_complete(client, -1, error);
    return TRUE;
  }

  gboolean get_driver(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
    if (!counters.kernel_driver_bound) return fail(client, ENODATA, false);
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_getdriver), nullptr);
    auto* request = reinterpret_cast<usbdevfs_getdriver*>(d->data);
    std::snprintf(request->driver, sizeof request->driver, "usbhid");
    g_object_unref(d);
    return succeed(client);
  }

  gboolean disconnect_claim(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_disconnect_claim), nullptr);
    const auto* request = reinterpret_cast<const usbdevfs_disconnect_claim*>(d->data);
    const unsigned interface_number = request->interface;
    g_object_unref(d);
    if (interface_number != id.interface_number) return fail(client, ENOENT, false);
    if (counters.kernel_driver_bound) ++counters.kernel_driver_detaches;
    counters.kernel_driver_bound = false;
    return claimed(client);
  }

  gboolean claim(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned int), nullptr);
    unsigned int interface_number = 0;
    std::memcpy(&interface_number, d->data, sizeof interface_number);
    g_object_unref(d);
    if (interface_number != id.interface_number) return fail(client, ENOENT, false);
    if (counters.kernel_driver_bound) return fail(client, EBUSY, false);  // usbhid holds it
    return claimed(client);
  }

  gboolean claimed(UMockdevIoctlClient* client) {
    counters.claimed = true;
    ++counters.claims;
    board.refresh_report();
    return succeed(client);
  }

  gboolean driver_ioctl(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
    UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_ioctl), nullptr);
    const auto* request = reinterpret_cast<const usbdevfs_ioctl*>(d->data);
    const int code = request->ioctl_code;
    g_object_unref(d);
    if (code == static_cast<int>(USBDEVFS_CONNECT)) {
      if (!counters.kernel_driver_bound) ++counters.kernel_driver_attaches;
      counters.kernel_driver_bound = true;
      return succeed(client);
    }
    if (code == static_cast<int>(USBDEVFS_DISCONNECT)) {
      if (!counters.kernel_driver_bound) return fail(client, ENODATA, false);
      ++counters.kernel_driver_detaches;
      counters.kernel_driver_bound = false;
      return succeed(client);
    }
    return fail(client, ENOTTY, false);
  }

  gboolean submit(UMockdevIoctlClient* client, ClientUrbs& urbs, UMockdevIoctlData* arg) {
    UMockdevIoctlData* urb_data = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), nullptr);
    const auto* urb = reinterpret_cast<const usbdevfs_urb*>(urb_data->data);
    HeldUrb held;
    held.client_addr = urb_data->client_addr;
    held.type = urb->type;
    held.endpoint = urb->endpoint;
    held.buffer_length = urb->buffer_length;
    UMockdevIoctlData* buffer = nullptr;
    if (urb->buffer_length > 0)
      buffer = umockdev_ioctl_data_resolve(urb_data, offsetof(usbdevfs_urb, buffer),
                                           static_cast<gsize>(urb->buffer_length), nullptr);
    const std::span<const std::uint8_t> bytes =
        buffer != nullptr
            ? std::span<const std::uint8_t>(buffer->data, static_cast<std::size_t>(buffer->data_len))
            : std::span<const std::uint8_t>();
    gboolean result = TRUE;
    if (held.type == USBDEVFS_URB_TYPE_CONTROL) {
      control(held, bytes);
      urbs.completed.push_back(std::move(held));
      result = succeed(client);
    } else if (held.type != USBDEVFS_URB_TYPE_INTERRUPT ||
               (held.endpoint != id.in_endpoint && held.endpoint != id.out_endpoint)) {
      result = fail(client, EINVAL, false);
    } else if (halted.contains(held.endpoint)) {
      held.status = -EPIPE;  // the board answers every token on a halted endpoint with STALL
      urbs.completed.push_back(std::move(held));
      result = succeed(client);
    } else if (held.endpoint == id.out_endpoint) {
      ++counters.out_submitted;
      board.on_out_report(bytes);
      held.status = 0;
      held.data.clear();
      urbs.completed.push_back(std::move(held));
      answer_in_tokens(urbs);
      result = succeed(client);
    } else {
      ++counters.in_submitted;
      urbs.waiting_in.push_back(std::move(held));
      answer_in_tokens(urbs);
      result = succeed(client);
    }
    if (buffer != nullptr) g_object_unref(buffer);
    g_object_unref(urb_data);
    counters.in_flight_in = urbs.waiting_in.size();
    return result;
  }

  /// The board answers the oldest waiting IN URB when it has a report.
  void answer_in_tokens(ClientUrbs& urbs) {
    while (!urbs.waiting_in.empty()) {
      HeldUrb& urb = urbs.waiting_in.front();
      std::vector<std::uint8_t> report(static_cast<std::size_t>(urb.buffer_length));
      std::size_t length = 0;
      if (!board.take_in_report(report, length)) return;
      report.resize(length);
      urb.data = std::move(report);
      urb.status = 0;
      urbs.completed.push_back(std::move(urb));
      urbs.waiting_in.pop_front();
    }
  }

  /// Standard requests on endpoint 0 (USB 2.0 9.4): GET_DESCRIPTOR(STRING)
  /// is all libusb needs from the board here; anything else stalls.
  void control(HeldUrb& held, std::span<const std::uint8_t> bytes) {
    ++counters.control_transfers;
    held.data_offset = 8;
    held.status = -EPIPE;
    if (bytes.size() < 8) return;
    const unsigned request_type = bytes[0], request = bytes[1];
    const unsigned value = bytes[2] | (bytes[3] << 8U);
    const std::size_t length = bytes[6] | (bytes[7] << 8U);
    if (request_type != 0x80 || request != 0x06 || (value >> 8U) != 0x03) return;
    const unsigned index = value & 0xFFU;
    std::vector<std::uint8_t> descriptor;
    if (index == 0)
      descriptor = {4, 3, 0x09, 0x04};  // LANGID en-US
    else if (index == 1)
      descriptor = string_descriptor(id.manufacturer);
    else if (index == 2)
      descriptor = string_descriptor(id.product);
    else if (index == 3)
      descriptor = string_descriptor(id.serial);
    else
      return;
    if (descriptor.size() > length) descriptor.resize(length);
    held.data = std::move(descriptor);
    held.status = 0;
  }

  gboolean discard(UMockdevIoctlClient* client, ClientUrbs& urbs, UMockdevIoctlData* arg) {
    gulong urb_address = 0;
    std::memcpy(&urb_address, arg->data, sizeof urb_address);
    for (auto it = urbs.waiting_in.begin(); it != urbs.waiting_in.end(); ++it) {
      if (it->client_addr != urb_address) continue;
      HeldUrb urb = std::move(*it);
      urbs.waiting_in.erase(it);
      urb.status = -ENOENT;
      urb.data.clear();
      urbs.completed.push_back(std::move(urb));
      ++counters.discarded;
      counters.in_flight_in = urbs.waiting_in.size();
      return succeed(client);
    }
    return fail(client, EINVAL, false);  // already completed: the kernel says EINVAL too
  }

  /// Hands the oldest completed URB back: the client's pointer variable gets
  /// the URB's address, the URB its status and length, the buffer its data.
  /// Everything is resolved afresh from the client's memory, so the same code
  /// serves a client in this process and one in another process.
  gboolean reap(UMockdevIoctlClient* client, ClientUrbs& urbs, UMockdevIoctlData* arg, bool gone) {
    if (urbs.completed.empty()) return fail(client, gone ? ENODEV : EAGAIN, gone);
    HeldUrb held = std::move(urbs.completed.front());
    urbs.completed.pop_front();
    UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(gulong), nullptr);
    std::memcpy(pointer->data, &held.client_addr, sizeof held.client_addr);
    UMockdevIoctlData* urb_data = umockdev_ioctl_data_resolve(pointer, 0, sizeof(usbdevfs_urb), nullptr);
    auto* urb = reinterpret_cast<usbdevfs_urb*>(urb_data->data);
    urb->status = held.status;
    urb->actual_length = static_cast<int>(held.data.size());
    if (held.endpoint == id.out_endpoint && held.type == USBDEVFS_URB_TYPE_INTERRUPT && held.status == 0)
      urb->actual_length = held.buffer_length;
    if (!held.data.empty()) {
      UMockdevIoctlData* buffer = umockdev_ioctl_data_resolve(
          urb_data, offsetof(usbdevfs_urb, buffer), static_cast<gsize>(held.buffer_length), nullptr);
      std::memcpy(
          buffer->data + held.data_offset, held.data.data(),
          std::min(held.data.size(), static_cast<std::size_t>(held.buffer_length) - held.data_offset));
      g_object_unref(buffer);
    }
    g_object_unref(urb_data);
    g_object_unref(pointer);
    ++counters.reaped;
    return succeed(client);
  }
};

UmockdevUsbBoard::UmockdevUsbBoard(const EmulatedUsbIdentity& identity, SimulatedBoard& board)
    : state_(std::make_unique<State>(identity, board)) {
  State& s = *state_;
  if (!preload_active())
    throw std::runtime_error(
        "UmockdevUsbBoard needs libumockdev-preload in this process (link it with --no-as-needed, or "
        "LD_PRELOAD): umockdev_testbed_uevent() and remove_device() take /sys paths only the preload maps");
  s.testbed = umockdev_testbed_new();
  if (s.testbed == nullptr) throw std::runtime_error("umockdev_testbed_new failed");
  s.handler = umockdev_ioctl_base_new();
  g_signal_connect(s.handler, "handle-ioctl", G_CALLBACK(&State::on_ioctl), &s);
  g_signal_connect(s.handler, "client-connected", G_CALLBACK(&State::on_connected), &s);
  s.add_root_hub();
  s.address = identity.first_address;
  // The handler first, so libusb can open the node as soon as the add uevent arrives.
  if (!umockdev_testbed_attach_ioctl(s.testbed, s.node_for(s.address).c_str(), s.handler, nullptr))
    throw std::runtime_error("umockdev_testbed_attach_ioctl failed for " + s.node_for(s.address));
  {
    const std::lock_guard lock(s.mutex);
    s.plug_locked_parts();
  }
  s.add_board();
}

UmockdevUsbBoard::~UmockdevUsbBoard() {
  g_clear_object(&state_->handler);
  g_clear_object(&state_->testbed);
}

std::string UmockdevUsbBoard::root_dir() const {
  gchar* dir = umockdev_testbed_get_root_dir(state_->testbed);
  std::string result = dir != nullptr ? dir : "";
  g_free(dir);
  return result;
}

std::string UmockdevUsbBoard::devnode() const {
  const std::lock_guard lock(state_->mutex);
  return state_->node_for(state_->address);
}

std::string UmockdevUsbBoard::port_path() const { return state_->port_name(); }

void UmockdevUsbBoard::unplug() {
  State& s = *state_;
  {
    const std::lock_guard lock(s.mutex);
    if (!s.counters.plugged) return;
    s.current_devnode.clear();
    s.counters.plugged = false;
    s.counters.claimed = false;
    for (auto& [client, urbs] : s.clients) {
      // The host controller driver gives back every URB of a vanished device with -ESHUTDOWN.
      for (HeldUrb& urb : urbs.waiting_in) {
        urb.status = -ESHUTDOWN;
        urb.data.clear();
        urbs.completed.push_back(std::move(urb));
      }
      urbs.waiting_in.clear();
    }
    s.counters.in_flight_in = 0;
  }
  umockdev_testbed_uevent(s.testbed, s.sysfs_path().c_str(), "remove");
  umockdev_testbed_remove_device(s.testbed, s.sysfs_path().c_str());
}

void UmockdevUsbBoard::replug() {
  State& s = *state_;
  std::string node;
  {
    const std::lock_guard lock(s.mutex);
    if (s.counters.plugged) return;
    ++s.address;
    node = s.node_for(s.address);
  }
  if (!umockdev_testbed_attach_ioctl(s.testbed, node.c_str(), s.handler, nullptr))
    throw std::runtime_error("umockdev_testbed_attach_ioctl failed for " + node);
  s.board.power_on();
  {
    const std::lock_guard lock(s.mutex);
    s.plug_locked_parts();
  }
  s.add_board();
}

void UmockdevUsbBoard::stall(std::uint8_t endpoint) {
  State& s = *state_;
  const std::lock_guard lock(s.mutex);
  s.halted.insert(endpoint);
  if ((endpoint & 0x80U) == 0) return;
  for (auto& [client, urbs] : s.clients) {
    for (HeldUrb& urb : urbs.waiting_in) {
      urb.status = -EPIPE;
      urbs.completed.push_back(std::move(urb));
    }
    urbs.waiting_in.clear();
  }
  s.counters.in_flight_in = 0;
}

UsbTestbedCounters UmockdevUsbBoard::counters() const {
  const std::lock_guard lock(state_->mutex);
  return state_->counters;
}

SimulatedBoard& UmockdevUsbBoard::board() noexcept { return state_->board; }

bool UmockdevUsbBoard::preload_active() {
  // umockdev_in_mock_environment() looks at LD_PRELOAD only; a test linked
  // with the preload library (--no-as-needed) has it without the variable.
  // Whoever provides ioctl() to this process is the answer.
  Dl_info info{};
  void* ioctl_symbol = dlsym(RTLD_DEFAULT, "ioctl");
  return ioctl_symbol != nullptr && dladdr(ioctl_symbol, &info) != 0 && info.dli_fname != nullptr &&
         std::strstr(info.dli_fname, "umockdev-preload") != nullptr;
}

}  // namespace hapticd::drivers::usb_hid::sim
