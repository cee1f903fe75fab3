#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

#include "drivers/gpio_pwm/transport_error.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <linux/gpio.h>
#include <poll.h>
#include <sys/stat.h>
#include <umockdev.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string_view>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

constexpr const char* preload_library = "libumockdev-preload.so.0";
constexpr std::size_t event_queue_depth = 16;  // the kernel's kfifo per line event request
constexpr int gpio_major = 254;

std::string node_of_slot(unsigned slot) { return "/dev/umockdev-gpio/request" + std::to_string(slot); }

}  // namespace

bool umockdev_preload_active() {
  // Loaded into this process, whatever LD_PRELOAD says. Not "who provides
  // ioctl()": under ASan the executable's interceptor does, and forwards to
  // the preload's wrapper behind it.
  void* handle = dlopen(preload_library, RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return false;
  dlclose(handle);  // NOLOAD took a reference of its own
  return true;
}

// getenv/setenv: called at program start, before any thread.
bool ensure_umockdev_preload(int argc, char** argv) {
  if (umockdev_preload_active()) return true;
  const char* old = std::getenv("LD_PRELOAD");  // NOLINT(concurrency-mt-unsafe)
  if (old != nullptr && std::string_view(old).find("libumockdev-preload") != std::string_view::npos) {
    std::fprintf(stderr,
                 "LD_PRELOAD names %s but it is not loaded in this process: a broken install (the build "
                 "links umockdev; apt-get install libumockdev0)\n",
                 preload_library);
    return false;
  }
  std::string value = preload_library;
  if (old != nullptr && old[0] != '\0') value += std::string(":") + old;
  ::setenv("LD_PRELOAD", value.c_str(), 1);  // NOLINT(concurrency-mt-unsafe)
  std::vector<char*> args(argv, argv + argc);
  args.push_back(nullptr);
  ::execv("/proc/self/exe", args.data());
  std::perror("re-executing with libumockdev-preload.so.0");
  return false;
}

struct UmockdevGpioTestbed::Impl {
  struct Slot {
    std::string node;
    bool busy = false;
    int client_fd = -1;  // the fd given to the client (same process)
    int master_fd = -1;  // PTY master: the doorbell is written here
    int direct_fd = -1;  // our own slave fd: the doorbell is drained here
    bool doorbell = false;
    std::deque<gpioevent_data> queue;
    UMockdevIoctlClient* bound_client = nullptr;  // the connection of client_fd
    UMockdevIoctlClient* pending_read = nullptr;  // a blocking read waiting for an event
  };

  UmockdevGpioTestbed* owner = nullptr;
  UMockdevTestbed* testbed = nullptr;
  UMockdevIoctlBase* handler = nullptr;
  std::string root;
  std::string chip_node;
  std::vector<Slot> slots;
  std::atomic<std::uint64_t> dropped{0};
  std::atomic<std::uint64_t> served{0};
  ValuesObserver observer;     // guarded by the owner's mutex
  ReadObserver read_observer;  // guarded by the owner's mutex

  std::mutex& mutex() { return *owner->mutex_; }
  GpioChipModel& chip() { return *owner->chip_; }

  Slot* slot_of_node(const char* devnode) {
    for (Slot& s : slots)
      if (s.node == devnode) return &s;
    return nullptr;
  }
  RequestId id_of(const Slot& s) const { return static_cast<RequestId>(&s - slots.data()) + 1; }

  // The doorbell byte passes the PTY's line discipline asynchronously (a
  // kernel work item); wait, bounded, until the slave sees it, so poll() on
  // the client's fd is exact the moment the event is queued, as on the
  // kernel's event fd. poll(), not ioctl(FIONREAD): the preload forwards
  // that ioctl to the handler thread, which waits for the lock held here.
  void ring(Slot& s) {
    if (s.doorbell) return;
    const char byte = 1;
    if (::write(s.master_fd, &byte, 1) != 1) return;
    s.doorbell = true;
    pollfd slave{s.direct_fd, POLLIN, 0};
    constexpr int doorbell_wait_ms = 1000;
    while (::poll(&slave, 1, doorbell_wait_ms) < 0 && errno == EINTR) {
    }
  }
  void drain(Slot& s) {
    char buffer[64];
    while (::read(s.direct_fd, buffer, sizeof buffer) > 0) {
    }
    s.doorbell = false;
  }

  // Moves queued events into a read of `len` bytes; returns the bytes.
  long deliver(Slot& s, UMockdevIoctlData* arg) {
    const std::size_t room = static_cast<std::size_t>(arg->data_len) / sizeof(gpioevent_data);
    std::vector<guint8> bytes;
    while (!s.queue.empty() && bytes.size() / sizeof(gpioevent_data) < room) {
      const auto* p = reinterpret_cast<const guint8*>(&s.queue.front());
      bytes.insert(bytes.end(), p, p + sizeof(gpioevent_data));
      s.queue.pop_front();
    }
    umockdev_ioctl_data_update(arg, 0, bytes.data(), static_cast<gint>(bytes.size()));
    if (s.queue.empty()) drain(s);
    return static_cast<long>(bytes.size());
  }

  void release_slot(Slot& s) {
    chip().release(id_of(s));
    s.busy = false;
    s.client_fd = -1;
    s.queue.clear();
    drain(s);
    if (s.pending_read != nullptr) {
      g_object_unref(s.pending_read);
      s.pending_read = nullptr;
    }
    if (s.bound_client != nullptr) {
      g_object_unref(s.bound_client);
      s.bound_client = nullptr;
    }
  }

  // Releases the requests whose fd the client closed (lock held).
  void reap_closed() {
    for (Slot& s : slots) {
      if (s.busy && s.bound_client != nullptr && !umockdev_ioctl_client_get_connected(s.bound_client))
        release_slot(s);
    }
  }

  gboolean chip_ioctl(UMockdevIoctlClient* client, gulong request, UMockdevIoctlData* arg);
  gboolean request_ioctl(UMockdevIoctlClient* client, Slot& slot, gulong request, UMockdevIoctlData* arg);
  template <class Request, class Claim>
  void open_request(UMockdevIoctlClient* client, UMockdevIoctlData* arg, Claim claim);
};

namespace {

template <class T>
T* resolve(UMockdevIoctlData* arg, UMockdevIoctlData** holder) {
  *holder = umockdev_ioctl_data_resolve(arg, 0, sizeof(T), nullptr);
  return *holder == nullptr ? nullptr : reinterpret_cast<T*>((*holder)->data);
}

void complete_errno(UMockdevIoctlClient* client, int error) {
  umockdev_ioctl_client_complete(client, error == 0 ? 0 : -1, error);
}

}  // namespace

template <class Request, class Claim>
void UmockdevGpioTestbed::Impl::open_request(UMockdevIoctlClient* client, UMockdevIoctlData* arg,
                                             Claim claim) {
  UMockdevIoctlData* holder = nullptr;
  auto* req = resolve<Request>(arg, &holder);
  int error = 0;
  if (req == nullptr) {
    error = EFAULT;
  } else {
    std::lock_guard lock(mutex());
    reap_closed();
    Slot* free_slot = nullptr;
    for (Slot& s : slots) {
      if (!s.busy) {
        free_slot = &s;
        break;
      }
    }
    if (free_slot == nullptr) {
      error = EMFILE;
    } else if ((error = claim(chip(), id_of(*free_slot), *req)) == 0) {
      // Opened here, on umockdev's worker thread: the preload wraps this fd
      // as an emulated device, so the client's ioctls and reads on it come
      // back to this handler as requests of this slot.
      const int fd = ::open(free_slot->node.c_str(), O_RDWR | O_CLOEXEC);
      if (fd < 0) {
        error = errno;
        chip().release(id_of(*free_slot));
      } else {
        free_slot->busy = true;
        free_slot->client_fd = fd;
        free_slot->queue.clear();
        drain(*free_slot);
        req->fd = fd;
      }
    }
  }
  complete_errno(client, error);
  if (holder != nullptr) g_object_unref(holder);
}

gboolean UmockdevGpioTestbed::Impl::chip_ioctl(UMockdevIoctlClient* client, gulong request,
                                               UMockdevIoctlData* arg) {
  UMockdevIoctlData* holder = nullptr;
  int error = 0;
  switch (request) {
    case GPIO_GET_CHIPINFO_IOCTL: {
      auto* info = resolve<gpiochip_info>(arg, &holder);
      std::lock_guard lock(mutex());
      error = info == nullptr ? EFAULT : chip().chip_info(*info);
      break;
    }
    case GPIO_GET_LINEINFO_IOCTL: {
      auto* info = resolve<gpioline_info>(arg, &holder);
      std::lock_guard lock(mutex());
      reap_closed();  // a line released by a closed fd shows free, as in the kernel
      error = info == nullptr ? EFAULT : chip().line_info(*info);
      break;
    }
    case GPIO_GET_LINEHANDLE_IOCTL:
      open_request<gpiohandle_request>(
          client, arg, [](GpioChipModel& c, RequestId id, const auto& r) { return c.request_handle(id, r); });
      return TRUE;
    case GPIO_GET_LINEEVENT_IOCTL:
      open_request<gpioevent_request>(
          client, arg, [](GpioChipModel& c, RequestId id, const auto& r) { return c.request_event(id, r); });
      return TRUE;
    default:
      return FALSE;  // umockdev answers ENOTTY
  }
  complete_errno(client, error);
  if (holder != nullptr) g_object_unref(holder);
  return TRUE;
}

gboolean UmockdevGpioTestbed::Impl::request_ioctl(UMockdevIoctlClient* client, Slot& slot, gulong request,
                                                  UMockdevIoctlData* arg) {
  UMockdevIoctlData* holder = nullptr;
  int error = 0;
  ValuesObserver notify;
  switch (request) {
    case GPIOHANDLE_GET_LINE_VALUES_IOCTL: {
      auto* data = resolve<gpiohandle_data>(arg, &holder);
      std::lock_guard lock(mutex());
      error = data == nullptr ? EFAULT : chip().get_values(id_of(slot), *data);
      break;
    }
    case GPIOHANDLE_SET_LINE_VALUES_IOCTL: {
      auto* data = resolve<gpiohandle_data>(arg, &holder);
      std::lock_guard lock(mutex());
      error = data == nullptr ? EFAULT : chip().set_values(id_of(slot), *data);
      if (error == 0) notify = observer;
      break;
    }
    default:
      error = ENOTTY;  // GPIOHANDLE_SET_CONFIG_IOCTL and the rest: not emulated
      break;
  }
  // Before completing, without the lock: the client's ioctl returns once
  // the board has taken this period's outputs (lockstep).
  if (notify) notify(id_of(slot));
  complete_errno(client, error);
  if (holder != nullptr) g_object_unref(holder);
  return TRUE;
}

namespace {

using Impl = UmockdevGpioTestbed::Impl;

gboolean on_handle_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer data) {
  auto* impl = static_cast<Impl*>(data);
  impl->served.fetch_add(1, std::memory_order_relaxed);
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  const char* devnode = umockdev_ioctl_client_get_devnode(client);
  if (impl->chip_node == devnode) return impl->chip_ioctl(client, request, arg);
  Impl::Slot* slot = impl->slot_of_node(devnode);
  if (slot == nullptr) return FALSE;
  return impl->request_ioctl(client, *slot, request, arg);
}

// How one read of an event request's fd ends: now with a result, or later
// (a blocking read on an empty queue, completed by drive_input()).
struct ReadOutcome {
  bool now = true;
  long result = -1;
  int error = 0;
};

// Serves one read of an event request's fd (lineevent_read()); lock held.
ReadOutcome serve_read(Impl& impl, Impl::Slot& slot, UMockdevIoctlClient* client) {
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  const LineRequest* request = impl.chip().request(impl.id_of(slot));
  if (request == nullptr || request->kind != LineRequest::Kind::event ||
      static_cast<std::size_t>(arg->data_len) < sizeof(gpioevent_data))
    return {true, -1, EINVAL};  // fewer bytes than one event; a handle has no read
  if (!slot.queue.empty()) return {true, impl.deliver(slot, arg), 0};
  const int flags = ::fcntl(slot.client_fd, F_GETFL);
  if (flags >= 0 && (flags & O_NONBLOCK) != 0) return {true, -1, EAGAIN};
  if (slot.pending_read != nullptr) g_object_unref(slot.pending_read);
  slot.pending_read = static_cast<UMockdevIoctlClient*>(g_object_ref(client));
  return {false, 0, 0};
}

gboolean on_handle_read(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer data) {
  auto* impl = static_cast<Impl*>(data);
  impl->served.fetch_add(1, std::memory_order_relaxed);
  Impl::Slot* slot = impl->slot_of_node(umockdev_ioctl_client_get_devnode(client));
  if (slot == nullptr) {
    umockdev_ioctl_client_complete(client, -1, EINVAL);  // the chip node has no read
    return TRUE;
  }
  UmockdevGpioTestbed::ReadObserver observer;
  std::optional<unsigned> line;
  ReadOutcome outcome;
  {
    std::lock_guard lock(impl->mutex());
    outcome = serve_read(*impl, *slot, client);
    observer = impl->read_observer;
    if (const LineRequest* r = impl->chip().request(impl->id_of(*slot)); r != nullptr && !r->offsets.empty())
      line = r->offsets.front();
  }
  // The events are taken from the queue, the client still waits for them:
  // what the observer drives arrives exactly between this read and the next.
  if (outcome.now && observer && line) observer(*line);
  if (outcome.now) umockdev_ioctl_client_complete(client, outcome.result, outcome.error);
  return TRUE;
}

// Binds a request node's connection to its slot. umockdev 0.17 neither
// emits "client-vanished" nor notifies "connected" when the client closes
// its fd, so closed connections are reaped lazily (reap_closed()).
void on_client_connected(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer data) {
  auto* impl = static_cast<Impl*>(data);
  Impl::Slot* slot = impl->slot_of_node(umockdev_ioctl_client_get_devnode(client));
  if (slot == nullptr) return;
  {
    std::lock_guard lock(impl->mutex());
    if (slot->bound_client != nullptr) g_object_unref(slot->bound_client);
    slot->bound_client = static_cast<UMockdevIoctlClient*>(g_object_ref(client));
  }
}

std::string sys_device_record(const std::string& path, const std::string& node, const std::string& subsystem,
                              int minor) {
  return "P: " + path + "\nN: " + node + "\nE: SUBSYSTEM=" + subsystem + "\nE: DEVNAME=/dev/" + node +
         "\nA: dev=" + std::to_string(gpio_major) + ":" + std::to_string(minor) + "\\n\n\n";
}

}  // namespace

UmockdevGpioTestbed::UmockdevGpioTestbed(const GpioChipSpec& spec)
    : mutex_(std::make_unique<std::mutex>()),
      chip_(std::make_unique<GpioChipModel>(spec.name, spec.label, spec.line_names)),
      impl_(std::make_unique<Impl>()) {
  if (!umockdev_preload_active()) {
    throw std::runtime_error(
        "UmockdevGpioTestbed: libumockdev-preload.so.0 is not loaded in this process (run under "
        "umockdev-wrapper, or call ensure_umockdev_preload() first; if LD_PRELOAD names it, the install is "
        "broken)");
  }
  Impl& impl = *impl_;
  impl.owner = this;
  impl.testbed = umockdev_testbed_new();
  gchar* root = umockdev_testbed_get_root_dir(impl.testbed);
  impl.root = root;
  g_free(root);
  impl.chip_node = "/dev/" + spec.name;
  impl.handler = umockdev_ioctl_base_new();
  g_signal_connect(impl.handler, "handle-ioctl", G_CALLBACK(on_handle_ioctl), &impl);
  g_signal_connect(impl.handler, "handle-read", G_CALLBACK(on_handle_read), &impl);
  g_signal_connect(impl.handler, "client-connected", G_CALLBACK(on_client_connected), &impl);

  std::string records = sys_device_record("/devices/platform/gpio-sim/" + spec.name, spec.name, "gpio", 0);
  impl.slots.resize(spec.request_slots);
  for (unsigned k = 0; k < spec.request_slots; ++k) {
    impl.slots[k].node = node_of_slot(k);
    records += sys_device_record("/devices/platform/umockdev-gpio/request" + std::to_string(k),
                                 impl.slots[k].node.substr(5), "misc", static_cast<int>(100 + k));
  }
  GError* error = nullptr;
  const auto fail = [&](const std::string& what) {
    const std::string message =
        what + (error != nullptr ? std::string(": ") + error->message : std::string());
    if (error != nullptr) g_error_free(error);
    throw std::runtime_error("UmockdevGpioTestbed: " + message);
  };
  if (!umockdev_testbed_attach_ioctl(impl.testbed, impl.chip_node.c_str(), impl.handler, &error))
    fail("attach " + impl.chip_node);
  for (auto& s : impl.slots)
    if (!umockdev_testbed_attach_ioctl(impl.testbed, s.node.c_str(), impl.handler, &error))
      fail("attach " + s.node);
  if (!umockdev_testbed_add_from_string(impl.testbed, records.c_str(), &error)) fail("add devices");

  // libgpiod trusts a chip only if /sys/bus/gpio/devices/<name>/dev matches
  // the node's major:minor (is_gpiochip_cdev()); umockdev 0.17 makes that
  // bus link itself, older versions for usb and pci only.
  namespace fs = std::filesystem;
  const std::string bus_link = impl.root + "/sys/bus/gpio/devices/" + spec.name;
  if (!fs::exists(fs::symlink_status(bus_link))) {
    fs::create_directories(impl.root + "/sys/bus/gpio/devices");
    fs::create_directory_symlink("../../../devices/platform/gpio-sim/" + spec.name, bus_link);
  }

  for (auto& s : impl.slots) {
    s.master_fd = umockdev_testbed_get_dev_fd(impl.testbed, s.node.c_str());
    char target[PATH_MAX] = {};
    const ssize_t n = ::readlink((impl.root + s.node).c_str(), target, sizeof target - 1);
    if (s.master_fd < 0 || n <= 0) fail("no PTY behind " + s.node);
    // The real /dev/pts path: not in the testbed, so not emulated.
    s.direct_fd = ::open(target, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (s.direct_fd < 0) fail(std::string("open ") + target + ": " + system_reason(errno));
  }
}

UmockdevGpioTestbed::~UmockdevGpioTestbed() {
  Impl& impl = *impl_;
  for (auto& s : impl.slots) {
    if (s.pending_read != nullptr) {
      umockdev_ioctl_client_complete(s.pending_read, -1, EIO);
      g_object_unref(s.pending_read);
    }
    if (s.bound_client != nullptr) g_object_unref(s.bound_client);
    if (s.direct_fd >= 0) ::close(s.direct_fd);
  }
  g_object_unref(impl.testbed);  // closes the PTY masters, removes the directory
  g_object_unref(impl.handler);
}

std::string UmockdevGpioTestbed::root_dir() const { return impl_->root; }
std::string UmockdevGpioTestbed::chip_path() const { return impl_->chip_node; }
std::string UmockdevGpioTestbed::host_path(const std::string& path) const { return impl_->root + path; }

void UmockdevGpioTestbed::drive_input(unsigned offset, bool physical_level, std::uint64_t timestamp_ns) {
  Impl& impl = *impl_;
  std::lock_guard lock(*mutex_);
  impl.reap_closed();
  const auto event = chip_->drive_input(offset, physical_level, timestamp_ns);
  if (!event) return;
  Impl::Slot& slot = impl.slots.at(event->request - 1);
  if (slot.queue.size() >= event_queue_depth) {
    impl.dropped.fetch_add(1, std::memory_order_relaxed);  // kfifo full: the new event is lost
    return;
  }
  slot.queue.push_back(event->data);
  if (slot.pending_read != nullptr) {
    UMockdevIoctlClient* client = slot.pending_read;
    slot.pending_read = nullptr;
    umockdev_ioctl_client_complete(client, impl.deliver(slot, umockdev_ioctl_client_get_arg(client)), 0);
    g_object_unref(client);
    return;
  }
  impl.ring(slot);
}

std::size_t UmockdevGpioTestbed::queued_events() {
  std::lock_guard lock(*mutex_);
  std::size_t n = 0;
  for (const auto& s : impl_->slots) {
    n += s.queue.size();
  }
  return n;
}

std::uint64_t UmockdevGpioTestbed::dropped_events() const { return impl_->dropped.load(); }
std::uint64_t UmockdevGpioTestbed::requests_served() const { return impl_->served.load(); }

void UmockdevGpioTestbed::reap_closed_locked() { impl_->reap_closed(); }

void UmockdevGpioTestbed::set_read_observer(ReadObserver observer) {
  std::lock_guard lock(*mutex_);
  impl_->read_observer = std::move(observer);
}

void UmockdevGpioTestbed::set_values_observer(ValuesObserver observer) {
  std::lock_guard lock(*mutex_);
  impl_->observer = std::move(observer);
}

}  // namespace hapticd::drivers::gpio_pwm::sim
