// hapticd --setup-check: the device the config names, found in /sys and
// /dev without opening the bus, and the period against the driver's link
// budget from the same pure functions the drivers use at configure.

#include <netdb.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "daemon/config/host_checks_setup.hpp"
#include "drivers/canopen/301/bus_budget.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"
#include "drivers/registry.hpp"
#include "drivers/usb_hid/link_budget.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"

namespace hapticd::daemon::config {
namespace {

namespace fs = std::filesystem;

std::string read_line(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

/// An absolute /sys or /dev path of the config, under the context's root.
std::string under_root(const std::string& path, const SetupContext& context) {
  if (path.rfind("/sys/", 0) == 0) return context.sys_root + path.substr(4);
  if (path.rfind("/dev/", 0) == 0) return context.dev_root + path.substr(4);
  return path;
}

SetupItem item(std::string name, Verdict verdict, std::string finding, std::string fix = {}) {
  return {std::move(name), verdict, std::move(finding), std::move(fix)};
}

std::string period_text(double period_s) { return drivers::usb_hid::format_duration(period_s); }

// ------------------------------------------------------------------ usb-hid

struct UsbFound {
  fs::path dir;  ///< /sys/bus/usb/devices/<name>
  std::string node;
};

std::optional<UsbFound> find_usb(const drivers::DriverParameters& p, const SetupContext& context) {
  const auto vendor = drivers::usb_hid::parse_usb_id(p.text("vendor_id"));
  const auto product = drivers::usb_hid::parse_usb_id(p.text("product_id"));
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(context.sys_root + "/bus/usb/devices", ec)) {
    const fs::path& dir = entry.path();
    const std::string v = read_line(dir / "idVendor");
    if (v.empty()) continue;
    try {
      if (std::stoul(v, nullptr, 16) != vendor ||
          std::stoul(read_line(dir / "idProduct"), nullptr, 16) != product)
        continue;
    } catch (const std::exception&) {
      continue;
    }
    if (!p.text("serial").empty() && read_line(dir / "serial") != p.text("serial")) continue;
    if (!p.text("path").empty() && dir.filename().string() != p.text("path")) continue;
    char node[48];
    std::snprintf(node, sizeof node, "/bus/usb/%03d/%03d", std::atoi(read_line(dir / "busnum").c_str()),
                  std::atoi(read_line(dir / "devnum").c_str()));
    return UsbFound{dir, context.dev_root + node};
  }
  return std::nullopt;
}

drivers::usb_hid::UsbSpeed usb_speed(const std::string& mbits) {
  using drivers::usb_hid::UsbSpeed;
  if (mbits == "1.5") return UsbSpeed::low;
  if (mbits == "12") return UsbSpeed::full;
  if (mbits == "480") return UsbSpeed::high;
  if (mbits == "5000") return UsbSpeed::super;
  if (mbits == "10000" || mbits == "20000") return UsbSpeed::super_plus;
  return UsbSpeed::unknown;
}

/// The interface's interrupt endpoint in `direction` ("in"/"out"): `wanted`
/// ("auto" or "0x81") as sysfs describes it (ep_XX/).
std::optional<drivers::usb_hid::EndpointInfo> usb_endpoint(const UsbFound& found, int interface,
                                                           const std::string& direction,
                                                           const std::string& wanted) {
  const fs::path dir = found.dir / (found.dir.filename().string() + ":1." + std::to_string(interface));
  std::error_code ec;
  std::map<unsigned, drivers::usb_hid::EndpointInfo> endpoints;  // in address order: "auto" is the first
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& ep = entry.path();
    if (ep.filename().string().rfind("ep_", 0) != 0 || read_line(ep / "type") != "Interrupt" ||
        read_line(ep / "direction") != direction)
      continue;
    try {
      drivers::usb_hid::EndpointInfo info;
      info.address = static_cast<std::uint8_t>(std::stoul(read_line(ep / "bEndpointAddress"), nullptr, 16));
      const auto packet = std::stoul(read_line(ep / "wMaxPacketSize"), nullptr, 16);
      info.max_packet_size = static_cast<std::uint16_t>(packet & 0x7FFU);
      info.extra_transactions = static_cast<std::uint8_t>((packet >> 11) & 0x3U);
      info.b_interval = static_cast<std::uint8_t>(std::stoul(read_line(ep / "bInterval"), nullptr, 16));
      info.speed = usb_speed(read_line(found.dir / "speed"));
      endpoints[info.address] = info;
    } catch (const std::exception&) {
    }
  }
  for (const auto& [address, info] : endpoints) {
    if (wanted == "auto" || std::stoul(wanted, nullptr, 0) == address) return info;
  }
  return std::nullopt;
}

std::vector<SetupItem> check_usb(const DaemonConfig& config, const drivers::DriverParameters& p,
                                 const SetupFacts& facts, const SetupContext& context) {
  const std::string ids = p.text("vendor_id") + ":" + p.text("product_id");
  const auto found = find_usb(p, context);
  if (!found) {
    return {item("device", Verdict::fail,
                 "no USB device " + ids + " in " + context.sys_root + "/bus/usb/devices",
                 "plug the board in (`lsusb` lists it), or correct device.usb-hid.vendor_id/product_id")};
  }
  std::vector<SetupItem> items;
  const std::string problem = access_problem(found->node, facts.user, read_write_access);
  items.push_back(
      problem.empty()
          ? item("device", Verdict::ok, "USB " + ids + " at " + found->node + ", open to " + facts.user.name)
          : item("device", Verdict::fail, "USB " + ids + " found: " + problem,
                 "the udev rule 70-hapticd-usb-hid.rules with your board's IDs, then re-plug it"));
  const int interface = static_cast<int>(p.integer("interface"));
  const auto in = usb_endpoint(*found, interface, "in", p.text("in_endpoint"));
  const auto out = usb_endpoint(*found, interface, "out", p.text("out_endpoint"));
  if (!in || !out) {
    items.push_back(
        item("period", Verdict::fail,
             "interface " + std::to_string(interface) + " has no interrupt " + (in ? "OUT" : "IN") +
                 " endpoint as configured",
             "device.usb-hid.interface, in_endpoint, out_endpoint (`lsusb -v` lists the endpoints)"));
    return items;
  }
  std::string line = drivers::usb_hid::check_endpoint(*in, config.loop.period_s, p.integer("in_report_size"));
  if (line.empty())
    line = drivers::usb_hid::check_endpoint(*out, config.loop.period_s, p.integer("out_report_size"));
  if (!line.empty()) {
    items.push_back(item("period", Verdict::fail, line, "a longer [loop] period, or a board polled faster"));
    return items;
  }
  const auto in_s = drivers::usb_hid::interrupt_interval_s(in->speed, in->b_interval).value_or(0);
  const auto out_s = drivers::usb_hid::interrupt_interval_s(out->speed, out->b_interval).value_or(0);
  items.push_back(
      item("period", Verdict::ok,
           "the endpoints (IN every " + period_text(in_s) + ", OUT every " + period_text(out_s) +
               ") carry a report every " + period_text(config.loop.period_s) + "; the link adds " +
               std::to_string(drivers::usb_hid::link_delay_periods(in_s, out_s, config.loop.period_s)) +
               " periods of delay"));
  return items;
}

// ------------------------------------------------------------------ canopen

std::optional<std::uint32_t> can_bitrate(const std::string& details) {
  try {
    const auto j = nlohmann::json::parse(details);
    const auto& link = j.is_array() && !j.empty() ? j[0] : j;
    return link.at("linkinfo").at("info_data").at("bittiming").at("bitrate").get<std::uint32_t>();
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

SetupItem check_can_interface(const std::string& name, std::uint32_t bitrate, const SetupContext& context) {
  if (name.rfind("unix:", 0) == 0) {
    const std::string path = name.substr(5);
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode))
      return item("device", Verdict::ok, "the simulated drive's bus (unix: seam) listens at " + path);
    return item("device", Verdict::fail,
                "no socket at " + path + " (device.canopen.interface = \"" + name + "\")",
                "start the simulated drive: hapticd-devsim canopen --listen " + name);
  }
  const fs::path dir = fs::path(context.sys_root) / "class/net" / name;
  const std::string network_fix =
      "bring it up at the configured rate: the example 80-hapticd-can.network (share/doc/hapticd/examples/"
      "networkd), or ip link set " +
      name + " type can bitrate " + std::to_string(bitrate) + " && ip link set " + name + " up";
  if (!fs::exists(dir)) return item("device", Verdict::fail, "no network interface " + name, network_fix);
  if (read_line(dir / "type") != "280")  // ARPHRD_CAN
    return item("device", Verdict::fail,
                name + " is not a CAN interface (type " + read_line(dir / "type") + ")",
                "device.canopen.interface names the CAN interface (ip -details link lists them)");
  unsigned long flags = 0;
  try {
    flags = std::stoul(read_line(dir / "flags"), nullptr, 16);
  } catch (const std::exception&) {
  }
  if ((flags & 0x1U) == 0)  // IFF_UP
    return item("device", Verdict::fail, name + " is down", network_fix);
  const auto details = context.ip_details ? context.ip_details(name) : std::nullopt;
  const auto actual = details ? can_bitrate(*details) : std::nullopt;
  if (!actual)
    return item("device", Verdict::warning,
                name + " is up; its bit rate could not be read (ip -details link)",
                "check `ip -details link show " + name + "` says bitrate " + std::to_string(bitrate));
  if (*actual != bitrate)
    return item("device", Verdict::fail,
                name + " runs at " + drivers::canopen::cia301::format_bitrate(*actual) +
                    ", the config says " + drivers::canopen::cia301::format_bitrate(bitrate),
                network_fix + " (or device.canopen.bitrate = " + std::to_string(*actual) + ")");
  return item("device", Verdict::ok, name + " is up at " + drivers::canopen::cia301::format_bitrate(bitrate));
}

std::vector<SetupItem> check_canopen(const DaemonConfig& config, const drivers::DriverParameters& p,
                                     const SetupContext& context) {
  const auto bitrate = static_cast<std::uint32_t>(p.integer("bitrate"));
  std::vector<SetupItem> items{check_can_interface(p.text("interface"), bitrate, context)};
  const auto mapping = drivers::canopen::standard_mapping(static_cast<std::uint8_t>(p.integer("node_id")),
                                                          p.boolean("velocity_pdo"));
  const auto budget = drivers::canopen::cia301::check_bus_budget(drivers::canopen::cyclic_frames(mapping),
                                                                 config.loop.period_s, bitrate);
  items.push_back(item("period", budget.fits ? Verdict::ok : Verdict::fail, budget.summary,
                       budget.fits ? "" : "a longer [loop] period or a faster bus"));
  return items;
}

// ------------------------------------------------------------------- modbus

std::vector<SetupItem> check_modbus_rtu(const DaemonConfig& config, const drivers::DriverParameters& p,
                                        const SetupFacts& facts, const SetupContext& context) {
  std::vector<SetupItem> items;
  const std::string path = under_root(p.text("device"), context);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISCHR(st.st_mode)) {
    items.push_back(item("device", Verdict::fail, "no serial port " + p.text("device"),
                         "plug the adapter in (`ls /dev/serial/by-id`), or correct device.modbus.device"));
  } else if (const std::string problem = access_problem(path, facts.user, read_write_access);
             !problem.empty()) {
    items.push_back(item("device", Verdict::fail, problem,
                         "serial ports belong to group dialout: the unit's modbus-rtu drop-in adds "
                         "SupplementaryGroups=dialout (by hand: adduser " +
                             facts.user.name + " dialout)"));
  } else {
    items.push_back(item("device", Verdict::ok, p.text("device") + ", open to " + facts.user.name));
  }
  const auto modbus = drivers::modbus::modbus_config_from(p);
  const auto layout = drivers::modbus::plan_blocks(modbus.map);
  const auto cycle =
      drivers::modbus::cycle_time(modbus.serial, modbus.silence, modbus.turnaround_s, modbus.function_23,
                                  layout.layout.write_count, layout.layout.read_count);
  const double budget = modbus.link_budget * config.loop.period_s;
  std::ostringstream s;
  s << "one exchange at " << modbus.serial.baud << " baud takes " << period_text(cycle.total_s())
    << ", link_budget " << modbus.link_budget << " of " << period_text(config.loop.period_s) << " is "
    << period_text(budget);
  const bool fits = cycle.total_s() <= budget;
  items.push_back(item("period", fits ? Verdict::ok : Verdict::fail, s.str(),
                       fits ? ""
                            : "a period of at least " +
                                  period_text(drivers::modbus::shortest_period_s(cycle, modbus.link_budget)) +
                                  ", a faster baud rate, or TCP"));
  return items;
}

std::vector<SetupItem> check_modbus(const DaemonConfig& config, const drivers::DriverParameters& p,
                                    const SetupFacts& facts, const SetupContext& context) {
  if (p.text("transport") == "rtu") return check_modbus_rtu(config, p, facts, context);
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const std::string& host = p.text("host");
  const int error = ::getaddrinfo(host.c_str(), std::to_string(p.integer("port")).c_str(), &hints, &found);
  if (found != nullptr) ::freeaddrinfo(found);
  std::vector<SetupItem> items;
  items.push_back(error == 0
                      ? item("device", Verdict::ok, "the amplifier's address " + host + " resolves")
                      : item("device", Verdict::fail, host + " does not resolve: " + ::gai_strerror(error),
                             "correct device.modbus.host (an address or a name this host resolves)"));
  items.push_back(item("period", Verdict::ok,
                       "Modbus TCP: the round trip is measured when the daemon configures (" +
                           std::to_string(p.integer("rtt_samples")) + " samples; hapticd --check-config)"));
  return items;
}

// ----------------------------------------------------------------- gpio-pwm

std::string gpio_chip_path(const std::string& chip, const SetupContext& context) {
  if (chip.rfind("/dev/", 0) == 0) return under_root(chip, context);
  if (!chip.empty() && chip.find_first_not_of("0123456789") == std::string::npos)
    return context.dev_root + "/gpiochip" + chip;
  if (chip.rfind("gpiochip", 0) == 0) return context.dev_root + "/" + chip;
  return {};  // a label: libgpiod finds it at start
}

std::vector<SetupItem> check_gpio_pwm(const drivers::DriverParameters& p, const SetupFacts& facts,
                                      const SetupContext& context) {
  std::vector<SetupItem> items;
  const std::string chip = gpio_chip_path(p.text("chip"), context);
  const std::string udev_fix = "the udev rule 70-hapticd-gpio-pwm.rules (its KERNEL== names your chip)";
  if (chip.empty()) {
    items.push_back(item("device", Verdict::warning,
                         "chip \"" + p.text("chip") + "\" is a label: found at start",
                         "name the chip as gpiochipN (gpiodetect lists them) to have it checked here"));
  } else if (!fs::exists(chip)) {
    items.push_back(item("device", Verdict::fail, "no GPIO chip " + p.text("chip") + " (" + chip + ")",
                         "gpiodetect lists the chips: correct device.gpio-pwm.chip"));
  } else if (const std::string problem = access_problem(chip, facts.user, read_write_access);
             !problem.empty()) {
    items.push_back(item("device", Verdict::fail, "GPIO chip: " + problem, udev_fix));
  } else {
    items.push_back(item("device", Verdict::ok, "GPIO chip " + chip + ", open to " + facts.user.name));
  }
  const std::string pwm = under_root(p.text("pwm_chip"), context);
  const auto channel = p.integer("pwm_channel");
  long npwm = -1;
  try {
    npwm = std::stol(read_line(pwm + "/npwm"));
  } catch (const std::exception&) {
  }
  if (npwm < 0) {
    items.push_back(item("pwm", Verdict::fail, "no PWM chip at " + p.text("pwm_chip"),
                         "enable the PWM (a device-tree overlay), or correct device.gpio-pwm.pwm_chip"));
  } else if (channel >= npwm) {
    items.push_back(item("pwm", Verdict::fail,
                         p.text("pwm_chip") + " has " + std::to_string(npwm) + " channels, pwm_channel is " +
                             std::to_string(channel),
                         "device.gpio-pwm.pwm_channel below " + std::to_string(npwm)));
  } else if (const std::string problem = access_problem(pwm + "/export", facts.user, write_access);
             !problem.empty()) {
    items.push_back(item("pwm", Verdict::fail, problem, udev_fix));
  } else {
    items.push_back(item("pwm", Verdict::ok,
                         p.text("pwm_chip") + " channel " + std::to_string(channel) +
                             ": export writable by " + facts.user.name));
  }
  if (const std::string& counter = p.text("counter"); !counter.empty()) {
    const std::string count =
        under_root(counter, context) + "/count" + std::to_string(p.integer("counter_count")) + "/count";
    const std::string problem = access_problem(count, facts.user, read_access);
    items.push_back(problem.empty() ? item("counter", Verdict::ok, count + " readable")
                                    : item("counter", Verdict::fail, problem,
                                           "load the counter driver, or correct device.gpio-pwm.counter"));
  }
  items.push_back(item("period", Verdict::ok, "GPIO and PWM are local to this machine: no link delay"));
  return items;
}

}  // namespace

std::vector<SetupItem> check_device(const DaemonConfig& config, const SetupFacts& facts,
                                    const SetupContext& context) {
  const auto& device = config.device;
  const drivers::DriverDescription* driver = drivers::find_driver(device.driver);
  if (driver == nullptr || !driver->ready) {
    return {item("device", Verdict::fail, "device.driver = \"" + device.driver + "\" is not a ready driver",
                 "one of " + drivers::driver_names(true))};
  }
  std::map<std::string, drivers::ParameterValue, std::less<>> given;
  for (const auto& p : device.parameters) given[p.key] = p.value;
  try {
    const drivers::DriverParameters p(device.driver, driver->parameters, given);
    if (device.driver == "usb-hid") return check_usb(config, p, facts, context);
    if (device.driver == "canopen") return check_canopen(config, p, context);
    if (device.driver == "modbus") return check_modbus(config, p, facts, context);
    if (device.driver == "gpio-pwm") return check_gpio_pwm(p, facts, context);
  } catch (const std::exception& e) {
    return {item("device", Verdict::fail, std::string("[device.") + device.driver + "]: " + e.what(),
                 "correct the key it names (hapticd --check-config shows where)")};
  }
  return {item("device", Verdict::ok, device.driver + ": a simulated plant, no device to check"),
          item("period", Verdict::ok, "no link: the simulation steps within the period")};
}

}  // namespace hapticd::daemon::config
