// Device permissions without root (issue 23 item 2): the udev rules in
// config/*.rules, evaluated against devices in a umockdev testbed (the
// attributes and properties udev would see), give the hapticd group the
// USB board of config/usb-hid.toml, gpiochip0, pwmchip0's export and
// channel attributes and /dev/cpu_dma_latency, and nothing else; and the
// unit with each driver's drop-in allows exactly those devices
// (DeviceAllow=). No udevd runs here (udevadm test needs one, and the udev
// package), so the rules are parsed by this test: strictly, so a key or
// operator it does not know fails rather than passes.

#include <gtest/gtest.h>
#include <umockdev.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace device_permissions_test {

namespace {

namespace fs = std::filesystem;

struct Term {
  std::string key;  ///< SUBSYSTEM, KERNEL, ACTION, ATTR{x}, ENV{x}, GROUP, MODE, RUN
  std::string op;   ///< == != = +=
  std::string value;
};
struct Rule {
  std::string where;
  std::vector<Term> matches;
  std::vector<Term> assignments;
};

std::vector<Rule> parse_rules(const fs::path& file) {
  static const std::regex term(R"re(\s*([A-Z]+(?:\{[A-Za-z_]+\})?)\s*(==|!=|\+=|=)\s*"([^"]*)"\s*(,|$))re");
  static const std::set<std::string> match_keys{"SUBSYSTEM", "KERNEL", "ACTION"};
  static const std::set<std::string> assign_keys{"GROUP", "MODE", "RUN"};
  std::vector<Rule> rules;
  std::ifstream in(file);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t") == std::string::npos || line[line.find_first_not_of(" \t")] == '#')
      continue;
    Rule rule{file.filename().string() + ":" + std::to_string(n), {}, {}};
    auto it = std::sregex_iterator(line.begin(), line.end(), term);
    std::size_t consumed = 0;
    for (; it != std::sregex_iterator(); ++it) {
      if (static_cast<std::size_t>(it->position()) != consumed) break;
      consumed += static_cast<std::size_t>(it->length());
      Term t{(*it)[1], (*it)[2], (*it)[3]};
      const std::string base = t.key.substr(0, t.key.find('{'));
      const bool matching = t.op == "==" || t.op == "!=";
      if (matching && (match_keys.count(t.key) != 0 || base == "ATTR" || base == "ENV")) {
        rule.matches.push_back(t);
      } else if (!matching && assign_keys.count(t.key) != 0) {
        rule.assignments.push_back(t);
      } else {
        ADD_FAILURE() << rule.where << ": " << t.key << t.op << " is not a key this test knows";
      }
    }
    EXPECT_EQ(consumed, line.size()) << rule.where << ": cannot parse from column " << consumed << ": "
                                     << line;
    rules.push_back(rule);
  }
  return rules;
}

/// udev's glob: * ? [...] and | between alternatives.
bool udev_glob(const std::string& pattern, const std::string& text) {
  std::stringstream alternatives(pattern);
  std::string alt;
  while (std::getline(alternatives, alt, '|')) {
    std::string re;
    for (char c : alt) {
      if (c == '*')
        re += ".*";
      else if (c == '?')
        re += '.';
      else if (c == '[' || c == ']' || c == '-' || std::isalnum(static_cast<unsigned char>(c)) != 0)
        re += c;
      else
        re += std::string("\\") + c;
    }
    if (std::regex_match(text, std::regex(re))) return true;
  }
  return false;
}

/// A device as udev sees it in an event.
struct Event {
  std::string devpath;  ///< /devices/...
  std::string action;
  std::map<std::string, std::string> env;  ///< uevent properties, SUBSYSTEM included
  fs::path sys;                            ///< the testbed's directory of the device
};

std::string attribute(const Event& e, const std::string& name) {
  std::ifstream in(e.sys / name);
  std::string v;
  std::getline(in, v);
  return v;
}

bool matches(const Rule& rule, const Event& e) {
  for (const auto& t : rule.matches) {
    std::string have;
    if (t.key == "SUBSYSTEM")
      have = e.env.count("SUBSYSTEM") ? e.env.at("SUBSYSTEM") : "";
    else if (t.key == "KERNEL")
      have = fs::path(e.devpath).filename().string();
    else if (t.key == "ACTION")
      have = e.action;
    else if (t.key.rfind("ENV{", 0) == 0) {
      const std::string k = t.key.substr(4, t.key.size() - 5);
      have = e.env.count(k) ? e.env.at(k) : "";
    } else {
      have = attribute(e, t.key.substr(5, t.key.size() - 6));
    }
    if (udev_glob(t.value, have) != (t.op == "==")) return false;
  }
  return true;
}

/// What the rules do to the event: GROUP, MODE, and the RUN commands with
/// %p and %E{X} substituted, as udev would.
struct Outcome {
  std::string group, mode;
  std::vector<std::string> run;
};

Outcome run_rules(const std::vector<Rule>& rules, const Event& e) {
  Outcome o;
  for (const auto& rule : rules) {
    if (!matches(rule, e)) continue;
    for (const auto& a : rule.assignments) {
      if (a.key == "GROUP") o.group = a.value;
      if (a.key == "MODE") o.mode = a.value;
      if (a.key == "RUN") {
        std::string cmd = std::regex_replace(a.value, std::regex("%p"), e.devpath);
        for (const auto& [k, v] : e.env) cmd = std::regex_replace(cmd, std::regex("%E\\{" + k + "\\}"), v);
        o.run.push_back(cmd);
      }
    }
  }
  return o;
}

std::vector<Rule> all_rules() {
  std::vector<Rule> rules;
  for (const auto& entry : fs::directory_iterator(fs::path(HAPTICD_SOURCE_DIR) / "config")) {
    if (entry.path().extension() != ".rules") continue;
    for (auto& r : parse_rules(entry.path())) rules.push_back(std::move(r));
  }
  return rules;
}

class Testbed : public ::testing::Test {
 protected:
  void SetUp() override {
    bed = umockdev_testbed_new();
    gchar* dir = umockdev_testbed_get_root_dir(bed);  // transfer full: ours to free
    root = dir;
    g_free(dir);
  }
  void TearDown() override {
    g_object_unref(bed);
    fs::remove_all(root);
  }
  /// Adds a device record (umockdev's format) and returns its add event.
  Event add(const std::string& devpath, const std::string& record) {
    GError* error = nullptr;
    const std::string text = "P: " + devpath + "\n" + record;
    EXPECT_TRUE(umockdev_testbed_add_from_string(bed, text.c_str(), &error))
        << (error != nullptr ? error->message : "") << "\n"
        << text;
    Event e{devpath, "add", {}, fs::path(root) / ("sys" + devpath)};
    std::istringstream lines(record);
    std::string line;
    while (std::getline(lines, line)) {
      if (line.rfind("E: ", 0) != 0) continue;
      const std::size_t eq = line.find('=');
      e.env[line.substr(3, eq - 3)] = line.substr(eq + 1);
    }
    // What the testbed made of it: its subsystem link (udev's SUBSYSTEM).
    EXPECT_EQ(fs::read_symlink(e.sys / "subsystem").filename().string(), e.env["SUBSYSTEM"]) << devpath;
    return e;
  }

  UMockdevTestbed* bed = nullptr;
  std::string root;
};

const char* const usb_record =
    "E: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\nA: idVendor=%s\\n\nA: idProduct=%s\\n\nA: busnum=1\\n\n";

std::string usb(const char* vendor, const char* product) {
  char text[256];
  std::snprintf(text, sizeof text, usb_record, vendor, product);
  return text;
}

TEST_F(Testbed, UdevRulesGiveTheHapticdGroupItsDevicesAndNothingElse) {
  const auto rules = all_rules();
  ASSERT_FALSE(rules.empty());
  const Outcome board = run_rules(rules, add("/devices/pci0000:00/usb1/1-2", usb("1209", "0001")));
  EXPECT_EQ(board.group, "hapticd");
  EXPECT_EQ(board.mode, "0660");
  // Not another USB device, nor the board's interface (no usbfs node).
  EXPECT_EQ(run_rules(rules, add("/devices/pci0000:00/usb1/1-3", usb("046d", "c52b"))).group, "");
  EXPECT_EQ(run_rules(rules, add("/devices/pci0000:00/usb1/1-4", usb("1209", "0002"))).group, "");
  EXPECT_EQ(run_rules(rules, add("/devices/pci0000:00/usb1/1-2/1-2:1.0",
                                 "E: SUBSYSTEM=usb\nE: DEVTYPE=usb_interface\nA: idVendor=1209\\n\n"))
                .group,
            "");
  // The GPIO chip the driver's defaults name, not another.
  const Outcome chip = run_rules(rules, add("/devices/platform/soc/gpiochip0", "E: SUBSYSTEM=gpio\n"));
  EXPECT_EQ(chip.group, "hapticd");
  EXPECT_EQ(chip.mode, "0660");
  EXPECT_EQ(run_rules(rules, add("/devices/platform/soc/gpiochip1", "E: SUBSYSTEM=gpio\n")).group, "");
  // cpu_dma_latency, not the other misc devices.
  const Outcome dma = run_rules(rules, add("/devices/virtual/misc/cpu_dma_latency", "E: SUBSYSTEM=misc\n"));
  EXPECT_EQ(dma.group, "hapticd");
  EXPECT_EQ(dma.mode, "0660");
  EXPECT_EQ(run_rules(rules, add("/devices/virtual/misc/fuse", "E: SUBSYSTEM=misc\n")).group, "");
}

TEST_F(Testbed, PwmChipExportOnAddAndTheChannelsAttributesOnExport) {
  const auto rules = all_rules();
  const std::string chip = "/devices/platform/soc/pwm0/pwm/pwmchip0";
  Event e = add(chip, "E: SUBSYSTEM=pwm\nA: npwm=2\\n\nA: export=\nA: unexport=\n");
  const Outcome added = run_rules(rules, e);
  EXPECT_EQ(added.group, "");  // no node: the attributes themselves
  EXPECT_EQ(added.run, (std::vector<std::string>{"/bin/chgrp hapticd /sys" + chip + "/export",
                                                 "/bin/chmod g+w /sys" + chip + "/export"}));
  // Every path a RUN names is an attribute the testbed has.
  EXPECT_TRUE(fs::exists(e.sys / "export"));
  // The kernel's change event for `echo 0 > export` (EXPORT=pwm0).
  e.action = "change";
  e.env["EXPORT"] = "pwm0";
  const Outcome exported = run_rules(rules, e);
  const std::string attrs = "/sys" + chip + "/pwm0/period /sys" + chip + "/pwm0/duty_cycle /sys" + chip +
                            "/pwm0/enable /sys" + chip + "/pwm0/polarity";
  EXPECT_EQ(exported.run,
            (std::vector<std::string>{"/bin/chgrp hapticd " + attrs, "/bin/chmod g+w " + attrs}));
  // Neither unexport nor another chip.
  for (const auto& cmd : added.run) EXPECT_EQ(cmd.find("unexport"), std::string::npos) << cmd;
  Event other = add("/devices/platform/soc/pwm1/pwm/pwmchip1", "E: SUBSYSTEM=pwm\nA: npwm=2\\n\n");
  EXPECT_TRUE(run_rules(rules, other).run.empty());
  other.action = "change";
  other.env["EXPORT"] = "pwm0";
  EXPECT_TRUE(run_rules(rules, other).run.empty());
}

// ---------------------------------------------------------------- the unit

/// The DeviceAllow= and ReadWritePaths= lines of a unit file or drop-in.
std::multiset<std::string> lines_of(const fs::path& file, const std::string& key) {
  std::multiset<std::string> out;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + "=", 0) == 0) out.insert(line.substr(key.size() + 1));
  }
  return out;
}

const fs::path source_dir(HAPTICD_SOURCE_DIR);

TEST(UnitDevices, TheUnitAllowsWhatEveryDriverIsGrantedAndNothingMore) {
  // The one device the rules give every hapticd: with DeviceAllow= set, the
  // policy is closed (the pseudo-devices only besides).
  const auto unit = lines_of(source_dir / "systemd/hapticd.service.in", "DeviceAllow");
  EXPECT_EQ(unit, (std::multiset<std::string>{"/dev/cpu_dma_latency rw"}));
  for (const auto& policy : lines_of(source_dir / "systemd/hapticd.service.in", "DevicePolicy"))
    EXPECT_TRUE(policy == "closed" || policy == "strict") << policy;
}

TEST(UnitDevices, EachDriversDropInAllowsExactlyTheNodesItsRulesGrant) {
  // usbfs nodes (char major usb_device) for the board the rule grants;
  // GPIO chips (char major gpiochip) for gpiochip0, and pwmchip0's sysfs
  // directory writable again (ProtectKernelTunables=) for its attributes.
  EXPECT_EQ(lines_of(source_dir / "systemd/drivers/usb-hid.conf", "DeviceAllow"),
            (std::multiset<std::string>{"char-usb_device rw"}));
  EXPECT_EQ(lines_of(source_dir / "systemd/drivers/gpio-pwm.conf", "DeviceAllow"),
            (std::multiset<std::string>{"char-gpiochip rw"}));
  EXPECT_EQ(lines_of(source_dir / "systemd/drivers/gpio-pwm.conf", "ReadWritePaths"),
            (std::multiset<std::string>{"-/sys/class/pwm/pwmchip0"}));
  // The rules name the same chips.
  std::set<std::string> kernels;
  for (const auto& rule : all_rules())
    for (const auto& t : rule.matches)
      if (t.key == "KERNEL") kernels.insert(t.value);
  EXPECT_EQ(kernels, (std::set<std::string>{"gpiochip0", "pwmchip0", "cpu_dma_latency"}));
}

}  // namespace

}  // namespace device_permissions_test
