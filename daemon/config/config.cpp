#include "daemon/config/config.hpp"

#include "drivers/registry.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

#include <toml++/toml.h>

#include "daemon/telemetry/datagram.hpp"
#include "daemon/telemetry/udp_endpoint.hpp"
#include "daemon/telemetry/udp_telemetry.hpp"
#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::daemon::config {

namespace {

constexpr std::string_view builtin_source = "<built-in default>";

// Keep in sync with config/hapticd.toml (a test checks they parse equal).
constexpr std::string_view default_text =
    R"toml(# hapticd: default configuration (built into the daemon; docs/config.md).
[loop]
period = "1ms"
priority = 80
cpu = -1
require_rt = false
clock = "real"
overrun_limit = 10
duration = ""

[device]
driver = "loopback"
torque_limit = 1.0

# The loopback driver's own defaults (hapticd --list-drivers), as for a
# file that leaves these keys out: one source of defaults.
[device.loopback]
motion = "rotary"

[scene]
name = "spring-wheel"
integrator = "exact"

[control]
socket = ""
group = ""
max_clients = 16
max_message_bytes = 65536
idle_timeout = "300s"
cpu = -1

[recorder]
directory = ""
ring_seconds = 2
flush_interval = "100ms"
cpu = -1

[telemetry]
udp = ""
rate_hz = 100
channels = []
batch = 1
prefix = "hapticd"
)toml";

std::string format_number(double value) {
  // TOML: a float keeps its point, so it reads back as a float.
  std::string text = world::text::format_number(value);
  if (std::isfinite(value) && text.find_first_of(".eE") == std::string::npos) text += ".0";
  return text;
}

std::string quote(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  out += '"';
  return out;
}

/// The value as the user (roughly) wrote it, for messages.
std::string render(const toml::node& node) {
  if (const auto* s = node.as_string()) return quote(s->get());
  if (const auto* i = node.as_integer()) return std::to_string(i->get());
  if (const auto* f = node.as_floating_point()) {
    const double v = f->get();
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    return format_number(v);
  }
  if (const auto* b = node.as_boolean()) return b->get() ? "true" : "false";
  if (node.is_array()) return "[...]";
  if (node.is_table()) return "{...}";
  return "(a date/time)";
}

using world::text::join;

// Driver names come from the registry: every driver describes itself once.
std::string driver_list() { return drivers::driver_names(); }

bool is_driver_kind(std::string_view name) { return drivers::find_driver(name) != nullptr; }

using Entry = std::pair<const toml::key*, const toml::node*>;

/// Table entries in file order (toml::table iterates in key order).
std::vector<Entry> in_file_order(const toml::table& table) {
  std::vector<Entry> entries;
  for (auto&& [key, node] : table) entries.emplace_back(&key, &node);
  std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    const auto& pa = a.first->source().begin;
    const auto& pb = b.first->source().begin;
    return std::pair(pa.line, pa.column) < std::pair(pb.line, pb.column);
  });
  return entries;
}

class Parser {
 public:
  explicit Parser(std::string file) : file_(std::move(file)) {}

  SourcePosition position(const toml::source_region& region) const {
    return SourcePosition{file_, region.begin.line, region.begin.column};
  }

  [[noreturn]] void fail(const toml::source_region& region, std::string key, std::string_view message) const {
    throw ConfigError(position(region), std::move(key), message);
  }

  [[noreturn]] void wrong_type(const toml::node& node, const std::string& key,
                               std::string_view accepted) const {
    fail(node.source(), key,
         key + " = " + render(node) + " has the wrong type; accepted: " + std::string(accepted));
  }

  [[noreturn]] void out_of_range(const toml::node& node, const std::string& key,
                                 std::string_view accepted) const {
    fail(node.source(), key,
         key + " = " + render(node) + " is out of range; accepted: " + std::string(accepted));
  }

  [[noreturn]] void unknown_key(const toml::key& key, std::string_view section,
                                std::string_view accepted) const {
    fail(key.source(), std::string(section) + "." + std::string(key.str()),
         "unknown key '" + std::string(key.str()) + "' in [" + std::string(section) +
             "]; accepted: " + std::string(accepted));
  }

  std::string get_string(const toml::node& node, const std::string& key, std::string_view accepted) const {
    const auto* s = node.as_string();
    if (!s) wrong_type(node, key, accepted);
    return s->get();
  }

  bool get_bool(const toml::node& node, const std::string& key) const {
    const auto* b = node.as_boolean();
    if (!b) wrong_type(node, key, "true or false");
    return b->get();
  }

  std::int64_t get_integer(const toml::node& node, const std::string& key, std::int64_t lo, std::int64_t hi,
                           std::string_view accepted) const {
    const auto* i = node.as_integer();
    if (!i) wrong_type(node, key, accepted);
    if (i->get() < lo || i->get() > hi) out_of_range(node, key, accepted);
    return i->get();
  }

  /// A thread's CPU: -1 (anywhere) or an index.
  int get_cpu(const toml::node& node, const std::string& key) const {
    return static_cast<int>(
        get_integer(node, key, -1, 1023, "-1 (no pinning) or a CPU index from 0 to 1023"));
  }

  double get_number(const toml::node& node, const std::string& key, std::string_view accepted) const {
    double value = 0.0;
    if (const auto* i = node.as_integer()) {
      value = static_cast<double>(i->get());
    } else if (const auto* f = node.as_floating_point()) {
      value = f->get();
    } else {
      wrong_type(node, key, accepted);
    }
    if (!std::isfinite(value)) out_of_range(node, key, accepted);
    return value;
  }

  /// A duration: a string with suffix s, ms or us, or a number of seconds.
  double get_duration(const toml::node& node, const std::string& key, double lo, double hi,
                      std::string_view range_text) const {
    const std::string accepted =
        std::string(range_text) + " (a string with suffix s, ms or us, or a number of seconds)";
    double value = 0.0;
    if (const auto* s = node.as_string()) {
      const auto parsed = world::units::parse_duration_s(s->get());
      if (!parsed) {
        fail(node.source(), key, key + " = " + render(node) + " is not a duration; accepted: " + accepted);
      }
      value = *parsed;
    } else if (node.is_integer() || node.is_floating_point()) {
      value = get_number(node, key, accepted);
    } else {
      wrong_type(node, key, accepted);
    }
    // Relative tolerance so that "100us" == 100e-6 passes despite rounding.
    if (value < lo * (1.0 - 1e-9) || value > hi * (1.0 + 1e-9)) out_of_range(node, key, range_text);
    return value;
  }

  /// Flattens a free-form table into key -> (value, position).
  void collect(const toml::table& table, const std::string& prefix, const std::string& section,
               ParameterList& out, std::string_view skip = {}) const {
    for (const auto& [key, node] : in_file_order(table)) {
      if (!skip.empty() && key->str() == skip) continue;
      const std::string name =
          prefix.empty() ? std::string(key->str()) : prefix + "." + std::string(key->str());
      const std::string dotted = section + "." + name;
      if (const auto* sub = node->as_table()) {
        collect(*sub, name, section, out);
        continue;
      }
      ParameterValue value;
      if (const auto* s = node->as_string()) {
        value = s->get();
      } else if (const auto* b = node->as_boolean()) {
        value = b->get();
      } else if (node->is_integer() || node->is_floating_point()) {
        value = get_number(*node, dotted, "a finite number, a boolean or a string");
      } else {
        wrong_type(*node, dotted, "a number, a boolean or a string");
      }
      out.push_back(Parameter{name, std::move(value), position(node->source())});
    }
  }

  const toml::table& section_table(const toml::key& key, const toml::node& node) const {
    const auto* table = node.as_table();
    if (!table) {
      fail(
          key.source(), std::string(key.str()),
          "'" + std::string(key.str()) + "' must be a section [" + std::string(key.str()) + "], not a value");
    }
    return *table;
  }

  void parse_loop(const toml::table& table, LoopConfig& loop) const {
    static const std::string accepted =
        join({"period", "priority", "cpu", "require_rt", "clock", "overrun_limit", "duration"});
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "loop." + std::string(name);
      if (name == "period") {
        loop.period_s = get_duration(*node, dotted, 100e-6, 10e-3, "100us to 10ms");
      } else if (name == "priority") {
        loop.priority = static_cast<int>(get_integer(*node, dotted, 1, 99, "an integer from 1 to 99"));
      } else if (name == "cpu") {
        loop.cpu = get_cpu(*node, dotted);
      } else if (name == "require_rt") {
        loop.require_rt = get_bool(*node, dotted);
      } else if (name == "clock") {
        const std::string value = get_string(*node, dotted, "\"real\" or \"virtual\"");
        if (value == "real") {
          loop.clock = ClockKind::real;
        } else if (value == "virtual") {
          loop.clock = ClockKind::virtual_clock;
        } else {
          fail(node->source(), dotted,
               dotted + " = " + render(*node) + " is not a clock; accepted: \"real\" or \"virtual\"");
        }
      } else if (name == "overrun_limit") {
        loop.overrun_limit = static_cast<std::uint32_t>(
            get_integer(*node, dotted, 0, 1000000, "an integer from 0 (never) to 1000000"));
      } else if (name == "duration") {
        if (const auto* s = node->as_string(); s && s->get().empty()) {
          loop.duration_s.reset();
        } else {
          loop.duration_s =
              get_duration(*node, dotted, 1e-9, 1e9, "\"\" (run until signalled) or more than 0s");
        }
      } else {
        unknown_key(*key, "loop", accepted);
      }
    }
  }

  /// [device] max_velocity: "" (derived from the device) or a number > 0.
  std::optional<double> get_max_velocity(const toml::node& node, const std::string& key) const {
    const std::string accepted =
        "\"\" (derived from the device: docs/config.md) or a number greater than 0 (m/s or rad/s)";
    if (const auto* s = node.as_string()) {
      if (s->get().empty()) return std::nullopt;
      wrong_type(node, key, accepted);
    }
    const double value = get_number(node, key, accepted);
    if (!(value > 0.0)) out_of_range(node, key, accepted);
    return value;
  }

  /// [device] encoder, origin, origin_file, require_calibration (docs/config.md, "Calibration").
  bool parse_calibration_key(std::string_view name, const toml::node& node, DeviceConfig& device) const {
    const std::string dotted = "device." + std::string(name);
    if (name == "encoder") {
      const std::string accepted_encoder = "\"incremental\" or \"absolute\"";
      const std::string value = get_string(node, dotted, accepted_encoder);
      if (value != "incremental" && value != "absolute")
        fail(node.source(), dotted,
             dotted + " = " + render(node) + " is not accepted; accepted: " + accepted_encoder);
      device.encoder = value == "absolute" ? EncoderKind::absolute : EncoderKind::incremental;
    } else if (name == "origin") {
      const std::string accepted_origin =
          "\"session\" (a calibration lasts until hapticd stops) or \"persist\" (kept in the state "
          "directory and restored at start-up)";
      const std::string value = get_string(node, dotted, accepted_origin);
      if (value != "session" && value != "persist")
        fail(node.source(), dotted,
             dotted + " = " + render(node) + " is not accepted; accepted: " + accepted_origin);
      device.origin = value == "persist" ? OriginKeeping::persist : OriginKeeping::session;
      device.origin_where = position(node.source());
    } else if (name == "origin_file") {
      const std::string path =
          get_string(node, dotted, "\"\" (origin.toml in the state directory) or a file path");
      device.origin_file =
          path.empty() || file_ == builtin_source
              ? path
              : (std::filesystem::path(file_).parent_path() / path).lexically_normal().string();
      device.origin_file_where = position(node.source());
    } else if (name == "require_calibration") {
      device.require_calibration = get_bool(node, dotted);
    } else {
      return false;
    }
    return true;
  }

  /// [device] axis_names: 1 to 6 distinct names of letters, digits and _.
  std::vector<std::string> get_axis_names(const toml::node& node, const std::string& key) const {
    const std::string accepted =
        "an array of 1 to 6 distinct axis names of 1 to 16 letters, digits or _, e.g. [\"x\", \"y\"]";
    const auto* array = node.as_array();
    if (array == nullptr) wrong_type(node, key, accepted);
    if (array->empty() || array->size() > 6) out_of_range(node, key, accepted);
    std::vector<std::string> names;
    for (const auto& entry : *array) {
      const std::string name = get_string(entry, key, accepted);
      const bool word =
          !name.empty() && name.size() <= 16 &&
          std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isalnum(c) || c == '_'; });
      if (!word || std::find(names.begin(), names.end(), name) != names.end())
        out_of_range(entry, key, accepted);
      names.push_back(name);
    }
    return names;
  }

  /// [device] axis_torque_limit: 1 to 6 limits greater than 0, N or N m.
  std::vector<double> get_axis_limits(const toml::node& node, const std::string& key) const {
    const std::string accepted =
        "an array of 1 to 6 numbers greater than 0, each axis' limit in N or N m (rotary joints), in the "
        "driver's axis order, e.g. [2.0, 5.0]";
    const auto* array = node.as_array();
    if (array == nullptr) wrong_type(node, key, accepted);
    if (array->empty() || array->size() > 6) out_of_range(node, key, accepted);
    std::vector<double> limits;
    for (const auto& entry : *array) {
      const double limit = get_number(entry, key, accepted);
      if (!(limit > 0.0)) out_of_range(entry, key, accepted);
      limits.push_back(limit);
    }
    return limits;
  }

  /// [device] kinematics: "cartesian" or "pantograph" (checked against the
  /// driver once the whole [device] table is read: check_kinematics).
  std::string get_kinematics(const toml::node& node, const std::string& key) const {
    std::string value = get_string(node, key, "\"cartesian\" or \"pantograph\"");
    if (value != "cartesian" && value != "pantograph")
      out_of_range(node, key, "\"cartesian\" or \"pantograph\"");
    return value;
  }

  /// A pantograph needs a driver that simulates or drives one: today the
  /// loopback with [device.loopback] linkage = "pantograph"; and such a
  /// loopback needs kinematics = "pantograph" (its axes are joint angles).
  void check_kinematics(const toml::table& table, const DeviceConfig& device) const {
    const Parameter* linkage = nullptr;
    for (const auto& p : device.parameters) {
      if (p.key == "linkage") linkage = &p;
    }
    const auto* text = linkage == nullptr ? nullptr : std::get_if<std::string>(&linkage->value);
    const bool simulated = device.driver == "loopback" && text != nullptr && *text == "pantograph";
    const auto* node = table.get("kinematics");
    if (device.kinematics == "pantograph" && !simulated) {
      const std::string why =
          device.driver == "loopback"
              ? "the loopback simulates a pantograph only with [device.loopback] linkage = \"pantograph\""
              : "the " + device.driver +
                    " driver cannot provide a pantograph: it drives its axes one joint per task axis and "
                    "reports no linkage (world/kinematics.hpp); only the loopback simulates one";
      fail(node->source(), "device.kinematics",
           "device.kinematics = \"pantograph\" is not accepted here: " + why +
               "; accepted: \"cartesian\", or the loopback with [device.loopback] linkage = \"pantograph\"");
    }
    if (simulated && device.kinematics != "pantograph") {
      throw ConfigError(linkage->where, "device.loopback.linkage",
                        "device.loopback.linkage = \"pantograph\" reads joint angles of a linkage; it needs "
                        "[device] kinematics = \"pantograph\" (accepted: that, or linkage = \"cartesian\")");
    }
  }

  void parse_device(const toml::table& table, DeviceConfig& device) const {
    static const std::string accepted =
        "driver, torque_limit, axis_torque_limit, max_velocity, model, axis_names, kinematics, encoder, "
        "origin, "
        "origin_file, "
        "require_calibration, and a table [device.<driver>] for the selected driver";
    const std::string drivers = driver_list();
    // The driver first: the driver table's name is checked against it.
    if (const auto* node = table.get("driver")) {
      const std::string value = get_string(*node, "device.driver", drivers);
      if (!is_driver_kind(value)) {
        fail(node->source(), "device.driver",
             "device.driver = " + render(*node) + " is not a known driver; accepted: " + drivers);
      }
      device.driver = value;
      device.driver_where = position(node->source());
    }
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "device." + std::string(name);
      if (name == "driver") continue;
      if (name == "torque_limit") {
        const std::string range = "a number greater than 0 (N or N m)";
        device.torque_limit = get_number(*node, dotted, range);
        if (!(device.torque_limit > 0.0)) out_of_range(*node, dotted, range);
      } else if (name == "axis_torque_limit") {
        device.axis_torque_limit = get_axis_limits(*node, dotted);
        device.axis_torque_limit_where = position(node->source());
      } else if (name == "max_velocity") {
        device.max_velocity = get_max_velocity(*node, dotted);
        device.max_velocity_where = position(node->source());
      } else if (name == "model") {
        const std::string accepted_model =
            "the path of a model file written by `hapticctl identify` (relative to this file), or \"\"";
        const std::string path = get_string(*node, dotted, accepted_model);
        device.model = path.empty() || file_ == builtin_source
                           ? path
                           : (std::filesystem::path(file_).parent_path() / path).lexically_normal().string();
        device.model_where = position(node->source());
      } else if (parse_calibration_key(name, *node, device)) {
        continue;
      } else if (name == "axis_names") {
        device.axis_names = get_axis_names(*node, dotted);
        device.axis_names_where = position(node->source());
      } else if (name == "kinematics") {
        device.kinematics = get_kinematics(*node, dotted);
      } else if (const auto* sub = node->as_table(); sub && is_driver_kind(name)) {
        if (name != device.driver) {
          fail(key->source(), dotted,
               "[" + dotted + "] does not match device.driver = " + quote(device.driver) +
                   "; accepted: [device." + device.driver + "]");
        }
        device.table_where = position(key->source());
        collect(*sub, "", dotted, device.parameters);
      } else {
        unknown_key(*key, "device", accepted);
      }
    }
    check_kinematics(table, device);
  }

  void parse_scene(const toml::table& table, SceneConfig& scene) const {
    scene.parameters.clear();
    scene.name_where = scene.table_where;
    const std::string accepted = "a non-empty scene name (spring-wheel, spring-mass, wall, relay, free, ...)";
    for (const auto& [key, node] : in_file_order(table)) {
      if (key->str() != "name") continue;
      scene.name = get_string(*node, "scene.name", accepted);
      if (scene.name.empty()) out_of_range(*node, "scene.name", accepted);
      scene.name_where = position(node->source());
    }
    collect(table, "", "scene", scene.parameters, "name");
  }

  /// [gravity]: a stage's vertical axis (axis, mass, down) or the
  /// pantograph's links (link_masses, handle_mass), and acceleration
  /// (docs/config.md, "Gravity and a workspace").
  void parse_gravity(const toml::table& table, GravityConfig& gravity) const {
    static const std::string accepted =
        join({"axis", "mass", "down", "link_masses", "handle_mass", "acceleration"});
    gravity.configured = true;
    const toml::node* stage_key = nullptr;  // the first of axis, mass, down
    const toml::node* handle = nullptr;
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "gravity." + std::string(name);
      if (name == "axis" || name == "mass" || name == "down") {
        if (stage_key == nullptr) stage_key = node;
        parse_stage_gravity_key(name, *node, dotted, gravity);
      } else if (name == "link_masses") {
        gravity.link_masses = get_link_masses(*node, dotted);
        gravity.link_masses_where = position(node->source());
      } else if (name == "handle_mass") {
        gravity.handle_mass = get_number(*node, dotted, link_mass_range);
        if (!(gravity.handle_mass >= 0.0 && gravity.handle_mass <= 10.0))
          out_of_range(*node, dotted, link_mass_range);
        handle = node;
      } else if (name == "acceleration") {
        const std::string range = "m/s^2 greater than 0 and at most 30 (9.80665 on Earth)";
        gravity.acceleration = get_number(*node, dotted, range);
        if (!(gravity.acceleration > 0.0 && gravity.acceleration <= 30.0)) out_of_range(*node, dotted, range);
      } else {
        unknown_key(*key, "gravity", accepted);
      }
    }
    check_gravity_model(table, gravity, stage_key, handle);
  }

  static constexpr std::string_view link_mass_range = "a mass in kg from 0 to 10";

  /// axis, mass or down: a stage's vertical axis.
  void parse_stage_gravity_key(std::string_view name, const toml::node& node, const std::string& dotted,
                               GravityConfig& gravity) const {
    if (name == "axis") {
      gravity.axis = get_string(node, dotted, "the name of the vertical axis (device.axis_names)");
      gravity.axis_where = position(node.source());
    } else if (name == "mass") {
      const std::string range = "a mass in kg greater than 0 and at most 100";
      gravity.mass = get_number(node, dotted, range);
      if (!(gravity.mass > 0.0 && gravity.mass <= 100.0)) out_of_range(node, dotted, range);
      gravity.mass_where = position(node.source());
    } else {
      const std::string range = "\"negative\" (the axis points up) or \"positive\"";
      const std::string value = get_string(node, dotted, range);
      if (value != "negative" && value != "positive") out_of_range(node, dotted, range);
      gravity.down_positive = value == "positive";
    }
  }

  /// gravity.link_masses: the pantograph's four links, kg (world::PantographMasses' order).
  std::vector<double> get_link_masses(const toml::node& node, const std::string& key) const {
    const std::string accepted =
        "four masses in kg from 0 to 10: [proximal left, distal left, distal right, proximal right]";
    const auto* array = node.as_array();
    if (array == nullptr) wrong_type(node, key, accepted);
    if (array->size() != 4) out_of_range(node, key, accepted);
    std::vector<double> masses;
    for (const auto& entry : *array) {
      const double m = get_number(entry, key, accepted);
      if (!(m >= 0.0 && m <= 10.0)) out_of_range(entry, key, accepted);
      masses.push_back(m);
    }
    return masses;
  }

  /// Either a stage's model (axis and mass) or the pantograph's (link_masses), not both.
  void check_gravity_model(const toml::table& table, const GravityConfig& gravity,
                           const toml::node* stage_key, const toml::node* handle) const {
    const std::string models =
        "mass (one vertical linear axis, or a stage's vertical axis named by axis; down), or "
        "link_masses (the pantograph in a vertical plane; handle_mass); acceleration with either";
    if (!gravity.link_masses.empty()) {
      if (stage_key != nullptr)
        fail(stage_key->source(), "gravity",
             "[gravity] gives both a stage's axis, mass or down and the "
             "pantograph's link_masses; accepted: " +
                 models);
      return;
    }
    if (handle != nullptr)
      fail(handle->source(), "gravity.handle_mass",
           "gravity.handle_mass goes with link_masses (the pantograph); accepted: " + models);
    // axis is the device's to ask for: a stage names its vertical axis, one axis has none.
    if (gravity.mass_where.line == 0)
      fail(table.source(), "gravity.mass", "[gravity] needs mass (kg); accepted: " + models);
  }

  /// [workspace]: shape and the box's or sphere's parameters (checked by the scene planner).
  void parse_workspace(const toml::table& table, WorkspaceConfig& workspace) const {
    const std::string accepted = "\"box\" or \"sphere\"";
    workspace.parameters.clear();
    bool has_shape = false;
    for (const auto& [key, node] : in_file_order(table)) {
      if (key->str() != "shape") continue;
      workspace.shape = get_string(*node, "workspace.shape", accepted);
      if (workspace.shape != "box" && workspace.shape != "sphere")
        out_of_range(*node, "workspace.shape", accepted);
      workspace.shape_where = position(node->source());
      has_shape = true;
    }
    if (!has_shape) fail(table.source(), "workspace.shape", "[workspace] needs shape; accepted: " + accepted);
    collect(table, "", "workspace", workspace.parameters, "shape");
  }

  void parse_control(const toml::table& table, ControlConfig& control) const {
    static const std::string accepted =
        join({"socket", "group", "max_clients", "max_message_bytes", "idle_timeout", "cpu"});
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "control." + std::string(name);
      if (name == "socket") {
        const std::string range = "\"\" (default path) or a path of at most 107 bytes";
        control.socket = get_string(*node, dotted, range);
        if (control.socket.size() > 107) out_of_range(*node, dotted, range);
        control.socket_where = position(node->source());
      } else if (name == "group") {
        control.group = get_string(*node, dotted, "\"\" (owner only) or a group name");
        control.group_where = position(node->source());
      } else if (name == "max_clients") {
        control.max_clients =
            static_cast<std::uint32_t>(get_integer(*node, dotted, 1, 1024, "an integer from 1 to 1024"));
      } else if (name == "max_message_bytes") {
        control.max_message_bytes = static_cast<std::uint32_t>(
            get_integer(*node, dotted, 1024, 16777216, "an integer from 1024 to 16777216"));
      } else if (name == "idle_timeout") {
        control.idle_timeout_s = get_duration(*node, dotted, 0.0, 86400.0, "0s (never) to 86400s");
      } else if (name == "cpu") {
        control.cpu = get_cpu(*node, dotted);
      } else {
        unknown_key(*key, "control", accepted);
      }
    }
  }

  void parse_recorder(const toml::table& table, RecorderConfig& recorder) const {
    static const std::string accepted = join({"directory", "ring_seconds", "flush_interval", "cpu"});
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "recorder." + std::string(name);
      if (name == "directory") {
        recorder.directory =
            get_string(*node, dotted, "\"\" ($STATE_DIRECTORY/recordings or .) or a directory");
        recorder.directory_where = position(node->source());
      } else if (name == "ring_seconds") {
        const std::string range = "a number of seconds from 0.1 to 60";
        recorder.ring_seconds = get_number(*node, dotted, range);
        if (recorder.ring_seconds < 0.1 || recorder.ring_seconds > 60.0) out_of_range(*node, dotted, range);
      } else if (name == "flush_interval") {
        recorder.flush_interval_s = get_duration(*node, dotted, 1e-3, 10.0, "1ms to 10s");
      } else if (name == "cpu") {
        recorder.cpu = get_cpu(*node, dotted);
      } else {
        unknown_key(*key, "recorder", accepted);
      }
    }
  }

  void parse_telemetry(const toml::table& table, TelemetryConfig& telemetry) const {
    static const std::string accepted = join({"udp", "rate_hz", "channels", "batch", "prefix"});
    for (const auto& [key, node] : in_file_order(table)) {
      const std::string_view name = key->str();
      const std::string dotted = "telemetry." + std::string(name);
      if (name == "udp") {
        const std::string range = "\"\" (off) or " + std::string(telemetry::endpoint_syntax());
        telemetry.udp = get_string(*node, dotted, range);
        if (!telemetry.udp.empty() && !telemetry::parse_endpoint(telemetry.udp)) {
          fail(node->source(), dotted,
               dotted + " = " + render(*node) + " is not an address; accepted: " + range);
        }
        telemetry.udp_where = position(node->source());
      } else if (name == "rate_hz") {
        // The upper bound, the loop rate, is checked once [loop] is known.
        const std::string range =
            "a number of samples per second from 0.1 to the loop rate (1 / loop.period)";
        telemetry.rate_hz = get_number(*node, dotted, range);
        if (telemetry.rate_hz < telemetry::min_rate_hz * (1.0 - 1e-12)) out_of_range(*node, dotted, range);
        rate_node_ = node;
      } else if (name == "channels") {
        parse_channels(*node, dotted, telemetry);
      } else if (name == "batch") {
        telemetry.batch = static_cast<std::uint32_t>(get_integer(
            *node, dotted, 1, telemetry::max_batch, "an integer from 1 to 64 (samples per datagram)"));
      } else if (name == "prefix") {
        const std::string range = "1 to 32 of the characters A-Z a-z 0-9 _ -";
        telemetry.prefix = get_string(*node, dotted, range);
        if (!telemetry::valid_prefix(telemetry.prefix)) out_of_range(*node, dotted, range);
      } else {
        unknown_key(*key, "telemetry", accepted);
      }
    }
  }

  void parse_channels(const toml::node& node, const std::string& dotted, TelemetryConfig& telemetry) const {
    const std::string accepted =
        "an array of channel names, e.g. [\"position\", \"applied\"] ([] for every "
        "channel the recording has)";
    const auto* array = node.as_array();
    if (array == nullptr) wrong_type(node, dotted, accepted);
    telemetry.channels.clear();
    telemetry.channel_where.clear();
    telemetry.channels_where = position(node.source());
    for (const auto& entry : *array) {
      const std::string channel = get_string(entry, dotted, accepted);
      for (const auto& seen : telemetry.channels) {
        if (seen == channel) fail(entry.source(), dotted, dotted + " names \"" + channel + "\" twice");
      }
      telemetry.channels.push_back(channel);
      telemetry.channel_where.push_back(position(entry.source()));
    }
  }

  /// Keys whose range depends on another section's.
  void check_across(const DaemonConfig& config) const {
    const double loop_rate = 1.0 / config.loop.period_s;
    if (rate_node_ != nullptr && config.telemetry.rate_hz > loop_rate * (1.0 + 1e-9)) {
      fail(rate_node_->source(), "telemetry.rate_hz",
           "telemetry.rate_hz = " + render(*rate_node_) + " is out of range; accepted: 0.1 to " +
               format_number(loop_rate) + " (the loop rate, 1 / loop.period)");
    }
  }

  toml::table parse_toml(std::string_view text) const {
    try {
      return toml::parse(text, file_);
    } catch (const toml::parse_error& error) {
      fail(error.source(), "", "TOML syntax error: " + std::string(error.description()));
    }
  }

  /// A model file: one [model] table, flattened with positions.
  ParameterList parse_model(std::string_view text) const {
    const toml::table root = parse_toml(text);
    ParameterList out;
    bool found = false;
    for (const auto& [key, node] : in_file_order(root)) {
      if (key->str() != "model" || !node->is_table()) {
        fail(key->source(), std::string(key->str()),
             "unknown " + std::string(node->is_table() ? "section [" : "key '") + std::string(key->str()) +
                 (node->is_table() ? "]" : "'") + " in a model file; accepted: [model]");
      }
      collect(*node->as_table(), "", "model", out);
      found = true;
    }
    if (!found) fail(toml::source_region{}, "[model]", "a model file needs a [model] section");
    return out;
  }

  DaemonConfig parse(std::string_view text) const {
    const toml::table root = parse_toml(text);
    DaemonConfig config;
    config.source = file_;
    // Until a key says otherwise, what the file leaves out is blamed on the file.
    const SourcePosition whole_file{file_, 0, 0};
    config.device.driver_where = config.device.table_where = whole_file;
    config.device.origin_where = config.device.origin_file_where = whole_file;
    config.scene.name_where = config.scene.table_where = whole_file;
    config.control.socket_where = config.control.group_where = whole_file;
    config.recorder.directory_where = whole_file;
    config.telemetry.udp_where = config.telemetry.channels_where = whole_file;
    static const std::string sections =
        join({"loop", "device", "scene", "gravity", "workspace", "control", "recorder", "telemetry"});
    for (const auto& [key, node] : in_file_order(root)) {
      const std::string_view name = key->str();
      if (name == "loop") {
        parse_loop(section_table(*key, *node), config.loop);
      } else if (name == "device") {
        config.device.driver_where = config.device.table_where = position(key->source());
        config.device.origin_where = config.device.origin_file_where = position(key->source());
        parse_device(section_table(*key, *node), config.device);
      } else if (name == "scene") {
        config.scene.table_where = position(key->source());
        parse_scene(section_table(*key, *node), config.scene);
      } else if (name == "gravity") {
        config.gravity.table_where = position(key->source());
        parse_gravity(section_table(*key, *node), config.gravity);
      } else if (name == "workspace") {
        config.workspace.shape_where = position(key->source());
        parse_workspace(section_table(*key, *node), config.workspace);
      } else if (name == "control") {
        parse_control(section_table(*key, *node), config.control);
      } else if (name == "recorder") {
        parse_recorder(section_table(*key, *node), config.recorder);
      } else if (name == "telemetry") {
        parse_telemetry(section_table(*key, *node), config.telemetry);
      } else if (node->is_table()) {
        fail(key->source(), "[" + std::string(name) + "]",
             "unknown section [" + std::string(name) + "]; accepted: " + sections);
      } else {
        fail(key->source(), std::string(name),
             "unknown key '" + std::string(name) + "' outside any section; accepted sections: " + sections);
      }
    }
    check_across(config);
    return config;
  }

 private:
  std::string file_;
  // Set while parsing (parse() is const: these are scratch, mutable).
  mutable const toml::node* rate_node_ = nullptr;
};

}  // namespace

std::string SourcePosition::to_string() const {
  std::string out = file;
  if (line > 0) {
    out += ":" + std::to_string(line);
    if (column > 0) out += ":" + std::to_string(column);
  }
  return out;
}

std::string format_error(const SourcePosition& where, std::string_view message) {
  const std::string prefix = where.to_string();
  return prefix.empty() ? std::string(message) : prefix + ": " + std::string(message);
}

std::string to_toml(const ParameterValue& value) {
  if (const auto* d = std::get_if<double>(&value)) return format_number(*d);
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return quote(std::get<std::string>(value));
}

std::string_view to_string(ClockKind clock) noexcept { return clock == ClockKind::real ? "real" : "virtual"; }

std::string_view to_string(EncoderKind encoder) noexcept {
  return encoder == EncoderKind::absolute ? "absolute" : "incremental";
}

std::string_view to_string(OriginKeeping keeping) noexcept {
  return keeping == OriginKeeping::persist ? "persist" : "session";
}

std::size_t RecorderConfig::ring_capacity(double period_s) const noexcept {
  if (!(period_s > 0.0)) return 2;
  const double samples = std::ceil(ring_seconds / period_s - 1e-9);
  return std::max<std::size_t>(2, static_cast<std::size_t>(samples));
}

ConfigError::ConfigError(SourcePosition where, std::string key, std::string_view message)
    : std::runtime_error(format_error(where, message)), where_(std::move(where)), key_(std::move(key)) {}

DaemonConfig parse_config(std::string_view text, std::string_view source_name) {
  return Parser(std::string(source_name)).parse(text);
}

DaemonConfig load_config(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw ConfigError(SourcePosition{path.string(), 0, 0}, "", "cannot read the configuration file");
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    throw ConfigError(SourcePosition{path.string(), 0, 0}, "", "error reading the configuration file");
  return parse_config(text.str(), path.string());
}

ParameterList load_model_file(const std::filesystem::path& path, const SourcePosition& named_at) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::error_code ec;
    const bool regular = std::filesystem::is_regular_file(path, ec);
    const std::string reason = ec ? ec.message() : regular ? "not readable" : "not a regular file";
    throw ConfigError(named_at.file.empty() ? SourcePosition{path.string(), 0, 0} : named_at, "device.model",
                      "cannot read the model file " + path.string() + " (" + reason +
                          "); device.model names a file written by `hapticctl identify`, relative to the "
                          "config file");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return Parser(path.string()).parse_model(text.str());
}

DaemonConfig default_config() {
  DaemonConfig config = parse_config(default_text, builtin_source);
  return config;
}

std::string_view default_config_text() noexcept { return default_text; }

namespace {
/// The first entry of $STATE_DIRECTORY (systemd's StateDirectory=; colon-separated), "" without.
std::string_view state_directory(const char* state_directory_env) {
  if (state_directory_env == nullptr) return {};
  const std::string_view all(state_directory_env);
  return all.substr(0, all.find(':'));
}
}  // namespace

std::filesystem::path resolve_recording_directory(const RecorderConfig& recorder,
                                                  const char* state_directory_env) {
  if (!recorder.directory.empty()) return recorder.directory;
  if (const auto first = state_directory(state_directory_env); !first.empty())
    return std::filesystem::path(first) / "recordings";
  return ".";
}

std::filesystem::path resolve_origin_file(const DeviceConfig& device, const char* state_directory_env) {
  if (!device.origin_file.empty()) return device.origin_file;
  if (const auto first = state_directory(state_directory_env); !first.empty())
    return std::filesystem::path(first) / "origin.toml";
  return "origin.toml";
}

}  // namespace hapticd::daemon::config
