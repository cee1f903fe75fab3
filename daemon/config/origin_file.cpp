#include "daemon/config/origin_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <ctime>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <system_error>

#include <toml++/toml.h>

#include "world/text.hpp"

namespace hapticd::daemon::config {

namespace {

constexpr std::string_view header =
    "# hapticd: the device's origin (docs/config.md, \"Calibration\"). Written by hapticd at each\n"
    "# calibration; read at start-up with [device] origin = \"persist\". Not meant to be edited.\n";

std::string toml_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;  // no control characters in the file
    out += c;
  }
  return out + "\"";
}

std::string toml_number(double value) {
  std::string text = world::text::format_number(value);
  if (text.find_first_of(".eE") == std::string::npos) text += ".0";  // a TOML float stays a float
  return text;
}

/// The reader of one table: every key it knows once, typed, at its position.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string section, std::string_view source)
      : table_(table), section_(std::move(section)), source_(source) {}

  [[noreturn]] void fail(const toml::source_region& where, std::string_view message) const {
    std::ostringstream out;
    out << source_;
    if (where.begin.line > 0) out << ":" << where.begin.line << ":" << where.begin.column;
    out << ": " << message;
    throw OriginFileError(out.str());
  }
  const toml::node& need(std::string_view key) const {
    const toml::node* node = table_.get(key);
    if (node == nullptr)
      fail(table_.source(), "[" + section_ + "] has no " + std::string(key) +
                                "; an origin file written by "
                                "hapticd has it");
    return *node;
  }
  std::string text(std::string_view key, std::string_view accepted) const {
    const toml::node& node = need(key);
    const auto* s = node.as_string();
    if (s == nullptr) wrong(node, key, accepted);
    return s->get();
  }
  double real(std::string_view key, std::string_view accepted, bool non_negative = false) const {
    const toml::node& node = need(key);
    double value = 0.0;
    if (const auto* f = node.as_floating_point()) {
      value = f->get();
    } else if (const auto* i = node.as_integer()) {
      value = static_cast<double>(i->get());
    } else {
      wrong(node, key, accepted);
    }
    if (!std::isfinite(value) || (non_negative && value < 0.0)) wrong(node, key, accepted);
    return value;
  }
  std::int64_t integer(std::string_view key, std::int64_t lo, std::int64_t hi,
                       std::string_view accepted) const {
    const toml::node& node = need(key);
    const auto* i = node.as_integer();
    if (i == nullptr || i->get() < lo || i->get() > hi) wrong(node, key, accepted);
    return i->get();
  }
  std::string choice(std::string_view key, std::initializer_list<std::string_view> values) const {
    std::string accepted;
    for (const auto v : values) accepted += (accepted.empty() ? "" : " or ") + toml_string(v);
    std::string value = text(key, accepted);
    for (const auto v : values)
      if (value == v) return value;
    wrong(need(key), key, accepted);
  }
  /// Every key of the table is one of `known`.
  void only(std::initializer_list<std::string_view> known) const {
    for (auto&& [key, node] : table_) {
      bool ok = false;
      std::string accepted;
      for (const auto k : known) {
        ok = ok || key.str() == k;
        accepted += (accepted.empty() ? "" : ", ") + std::string(k);
      }
      if (!ok)
        fail(key.source(),
             "unknown key '" + std::string(key.str()) + "' in [" + section_ + "]; accepted: " + accepted);
    }
  }

 private:
  [[noreturn]] void wrong(const toml::node& node, std::string_view key, std::string_view accepted) const {
    std::string shown = "(not a number or text)";
    if (const auto* s = node.as_string()) shown = toml_string(s->get());
    if (const auto* i = node.as_integer()) shown = std::to_string(i->get());
    if (const auto* f = node.as_floating_point()) shown = world::text::format_number(f->get());
    if (const auto* b = node.as_boolean()) shown = b->get() ? "true" : "false";
    fail(node.source(), section_ + "." + std::string(key) + " = " + shown +
                            " is not accepted; accepted: " + std::string(accepted));
  }

  const toml::table& table_;
  std::string section_;
  std::string_view source_;
};

OriginIdentity parse_identity(const TableReader& r) {
  r.only({"driver", "device", "encoder", "motion", "resolution"});
  OriginIdentity id;
  id.driver = r.text("driver", "the driver's name, as [device] driver");
  id.device = r.text("device", "the device's identity as the driver gives it");
  id.encoder = r.choice("encoder", {"incremental", "absolute"});
  id.motion = r.choice("motion", {"rotary", "linear"});
  id.resolution = r.real("resolution", "a finite number >= 0 (m or rad per count; 0: continuous)", true);
  return id;
}

OriginRecord parse_record(const TableReader& origin, const TableReader& identity) {
  origin.only({"position", "unit", "set_by", "homing_method", "cycle", "set_at"});
  OriginRecord r;
  r.identity = parse_identity(identity);
  r.position = origin.real("position", "a finite number (m or rad, in the device's frame)");
  const std::string unit = origin.choice("unit", {"rad", "m"});
  if ((unit == "rad") != (r.identity.motion == "rotary"))
    origin.fail(origin.need("unit").source(),
                "origin.unit = " + toml_string(unit) + " does not match identity.motion = " +
                    toml_string(r.identity.motion) + "; accepted: \"rad\" for rotary, \"m\" for linear");
  r.set_by = origin.choice("set_by", {"zero", "homing"});
  if (r.set_by == "homing")
    r.homing_method =
        static_cast<int>(origin.integer("homing_method", -128, 127, "an integer -128..127 (CiA 402 0x6098)"));
  r.cycle =
      static_cast<std::uint64_t>(origin.integer("cycle", 0, INT64_MAX, "an integer >= 0 (loop cycles)"));
  r.set_at = origin.text("set_at", "a UTC time, e.g. \"2026-12-05T10:00:00Z\"");
  return r;
}

void fsync_directory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "open directory " + dir.string());
  const int result = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (result != 0) throw std::system_error(error, std::generic_category(), "fsync " + dir.string());
}

}  // namespace

std::string format_origin(const OriginRecord& r) {
  std::string out(header);
  out += "[origin]\nposition = " + toml_number(r.position) + "\n";
  out += "unit = " + toml_string(r.identity.motion == "linear" ? "m" : "rad") + "\n";
  out += "set_by = " + toml_string(r.set_by) + "\n";
  if (r.set_by == "homing") out += "homing_method = " + std::to_string(r.homing_method) + "\n";
  out += "cycle = " + std::to_string(r.cycle) + "\n";
  out += "set_at = " + toml_string(r.set_at) + "\n";
  out += "\n[identity]\ndriver = " + toml_string(r.identity.driver) + "\n";
  out += "device = " + toml_string(r.identity.device) + "\n";
  out += "encoder = " + toml_string(r.identity.encoder) + "\n";
  out += "motion = " + toml_string(r.identity.motion) + "\n";
  out += "resolution = " + toml_number(r.identity.resolution) + "\n";
  return out;
}

OriginRecord parse_origin(std::string_view text, std::string_view source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    TableReader(toml::table{}, "", source)
        .fail(e.source(), "not an origin file (TOML syntax error: " + std::string(e.description()) + ")");
  }
  const TableReader top(root, "", source);
  for (auto&& [key, node] : root) {
    if ((key.str() != "origin" && key.str() != "identity") || !node.is_table())
      top.fail(key.source(), "unknown " + std::string(node.is_table() ? "section [" : "key '") +
                                 std::string(key.str()) + (node.is_table() ? "]" : "'") +
                                 " in an origin file; accepted: [origin], [identity]");
  }
  const auto* origin = root["origin"].as_table();
  const auto* identity = root["identity"].as_table();
  if (origin == nullptr || identity == nullptr)
    top.fail({}, std::string("an origin file has the sections [origin] and [identity]; this one lacks [") +
                     (origin == nullptr ? "origin" : "identity") + "]");
  return parse_record(TableReader(*origin, "origin", source), TableReader(*identity, "identity", source));
}

std::string identity_mismatch(const OriginIdentity& stored, const OriginIdentity& device) {
  const std::pair<const char*, std::pair<std::string, std::string>> fields[] = {
      {"driver", {stored.driver, device.driver}},
      {"device", {stored.device, device.device}},
      {"encoder", {stored.encoder, device.encoder}},
      {"motion", {stored.motion, device.motion}},
      {"resolution",
       {world::text::format_number(stored.resolution), world::text::format_number(device.resolution)}},
  };
  for (const auto& [name, values] : fields) {
    if (values.first != values.second)
      return std::string("it was written for ") + name + " " + toml_string(values.first) +
             ", this device has " + toml_string(values.second);
  }
  return {};
}

std::optional<OriginRecord> load_origin_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec) && !ec) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw OriginFileError(path.string() + ": cannot read the origin file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw OriginFileError(path.string() + ": error reading the origin file");
  return parse_origin(text.str(), path.string());
}

void write_origin_file(const std::filesystem::path& path, const OriginRecord& record) {
  const std::string text = format_origin(record);
  const std::filesystem::path temporary = path.string() + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "create " + temporary.string());
  std::size_t written = 0;
  int error = 0;
  while (written < text.size() && error == 0) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno != EINTR) error = errno;
    if (n > 0) written += static_cast<std::size_t>(n);
  }
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  ::close(fd);
  if (error == 0 && ::rename(temporary.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(temporary.c_str());
    throw std::system_error(error, std::generic_category(), "write " + path.string());
  }
  fsync_directory(path.parent_path());
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

}  // namespace hapticd::daemon::config
