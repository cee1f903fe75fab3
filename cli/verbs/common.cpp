// Shared pieces of the daemon verbs: options, connection and error
// reporting, name=value arguments, human output.

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <utility>

#include "cli/verbs.hpp"
#include "client/assignment.hpp"
#include "client/socket_path.hpp"

namespace hapticctl {

using nlohmann::json;

void add_common_options(CLI::App& app, CommonOptions& opts) {
  if (app.get_option_no_throw("--socket") == nullptr) {
    app.add_option("--socket", opts.socket,
                   "hapticd control socket (default: $HAPTICD_SOCKET, else $RUNTIME_DIRECTORY, "
                   "$XDG_RUNTIME_DIR or /tmp when a daemon listens there, else the system service's "
                   "/run/hapticd/hapticd.sock)");
  }
  if (app.get_option_no_throw("--instance") == nullptr) {
    app.add_option("--instance,-i", opts.instance,
                   "talk to hapticd@NAME.service (socket /run/hapticd/NAME/hapticd.sock)")
        ->check([](const std::string& name) {
          return name.find('/') == std::string::npos && name != "." && name != ".."
                     ? std::string()
                     : "an instance name, no '/'";
        });
  }
  if (app.get_option_no_throw("--json") == nullptr) {
    app.add_flag("--json", opts.json, "print the daemon's result as JSON");
  }
  if (app.get_option_no_throw("--timeout") == nullptr) {
    // Bounded: 1e300 s would overflow the milliseconds it becomes.
    app.add_option("--timeout", opts.timeout_s, "seconds to wait for the daemon (up to 86400)")
        ->check(CLI::PositiveNumber)
        ->check(CLI::Range(0.0, 86400.0));
  }
}

int run(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? exit_code::ok : exit_code::usage;
  } catch (const Exit& e) {
    return e.code();
  }
  return exit_code::ok;
}

namespace detail {

namespace {
std::chrono::milliseconds timeout_of(const CommonOptions& opts) {
  return std::chrono::milliseconds(static_cast<long long>(std::ceil(opts.timeout_s * 1000.0)));
}
}  // namespace

hapticd::client::Client connect(const CommonOptions& opts) {
  std::string path = hapticd::client::resolve_client_socket_path(opts.socket, opts.instance);
  try {
    return hapticd::client::Client::connect(path, timeout_of(opts));
  } catch (...) {
    exit_for_current_exception("connect");
  }
}

void exit_for_current_exception(const std::string& method) {
  try {
    throw;
  } catch (const hapticd::rpc::RpcError& e) {
    std::cerr << "hapticctl: " << method << ": " << hapticd::rpc::code_name(e.code()) << ": " << e.what()
              << '\n';
    if (e.data().is_object()) {
      print_fields(std::cerr, e.data(), 2);
    } else if (!e.data().is_null()) {
      std::cerr << "  " << e.data().dump() << '\n';
    }
    throw Exit(exit_code::refused);
  } catch (const hapticd::client::ConnectError& e) {
    std::cerr << "hapticctl: " << e.what();
    if (e.error_number() == ENOENT || e.error_number() == ECONNREFUSED) {
      std::cerr << "; start it with `hapticd` or set --socket";
    }
    std::cerr << '\n';
    throw Exit(exit_code::unreachable);
  } catch (const hapticd::client::ProtocolError& e) {
    std::cerr << "hapticctl: " << method << ": " << e.what() << '\n';
    throw Exit(exit_code::refused);
  }
}

json call(const CommonOptions& opts, const std::string& method, const json& params) {
  auto client = connect(opts);
  try {
    return client.call(method, params);
  } catch (...) {
    exit_for_current_exception(method);
  }
}

json assignments(const std::vector<std::string>& words) {
  try {
    return hapticd::client::parse_assignments(words);
  } catch (const hapticd::client::AssignmentError& e) {
    std::cerr << "hapticctl: " << e.what() << '\n';
    throw Exit(exit_code::usage);
  }
}

namespace {
// Unit suffixes the daemon puts on member names (docs/protocol.md, "Units").
const std::pair<const char*, const char*> unit_suffixes[] = {{"_us", "us"}, {"_hz", "Hz"}, {"_s", "s"}};

const char* unit_of(const std::string& key, std::size_t* suffix_len) {
  for (const auto& [suffix, unit] : unit_suffixes) {
    std::string_view s(suffix);
    if (key.size() > s.size() && key.compare(key.size() - s.size(), s.size(), s) == 0) {
      *suffix_len = s.size();
      return unit;
    }
  }
  *suffix_len = 0;
  return nullptr;
}

}  // namespace

std::string scalar(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_null()) return "-";
  if (value.is_number_float()) {
    std::ostringstream s;
    s.precision(6);
    s << value.get<double>();
    return s.str();
  }
  return value.dump();
}

std::string display_key(const std::string& key) {
  std::size_t len = 0;
  return unit_of(key, &len) != nullptr ? key.substr(0, key.size() - len) : key;
}

std::string format_value(const std::string& key, const json& value) {
  std::size_t len = 0;
  const char* unit = unit_of(key, &len);
  std::string text = scalar(value);
  if (unit != nullptr && value.is_number()) text += std::string(" ") + unit;
  return text;
}

namespace {
void print_fields_with_unit(std::ostream& out, const json& object, int indent, const std::string& unit_key);
}  // namespace

void print_fields(std::ostream& out, const json& object, int indent) {
  print_fields_with_unit(out, object, indent, "");
}

namespace {
// unit_key: the parent's key when it carries a unit suffix ("latency_us":
// {"p50": 60}) that applies to children without one of their own.
void print_fields_with_unit(std::ostream& out, const json& object, int indent, const std::string& unit_key) {
  if (!object.is_object()) {
    out << std::string(static_cast<std::size_t>(indent), ' ') << scalar(object) << '\n';
    return;
  }
  std::size_t width = 0;
  for (const auto& [key, value] : object.items()) width = std::max(width, display_key(key).size());
  const std::string pad(static_cast<std::size_t>(indent), ' ');
  for (const auto& [key, value] : object.items()) {
    std::string name = display_key(key);
    const std::string& effective = name == key && !unit_key.empty() ? unit_key : key;
    out << pad << name << ':';
    if (value.is_object() && !value.empty()) {
      out << '\n';
      print_fields_with_unit(out, value, indent + 2,
                             effective == key && name == key ? std::string() : effective);
    } else if (value.is_array() && !value.empty() && value.front().is_object()) {
      out << '\n';
      for (const auto& item : value) print_fields_with_unit(out, item, indent + 2, "");
    } else if (value.is_array()) {
      std::string joined;
      for (const auto& item : value) joined += (joined.empty() ? "" : ", ") + scalar(item);
      out << std::string(width - name.size() + 1, ' ') << joined << '\n';
    } else {
      out << std::string(width - name.size() + 1, ' ') << format_value(effective, value) << '\n';
    }
  }
}
}  // namespace

void print_params(std::ostream& out, const json& parameters, const json& units) {
  if (!parameters.is_object() || parameters.empty()) {
    out << "(no parameters)\n";
    return;
  }
  std::vector<std::array<std::string, 3>> rows{{"NAME", "VALUE", "UNIT"}};
  for (const auto& [name, value] : parameters.items()) {
    const bool has_unit = units.is_object() && units.contains(name) && units[name].is_string();
    rows.push_back({name, scalar(value), has_unit ? units[name].get<std::string>() : ""});
  }
  std::size_t w0 = 0, w1 = 0;
  for (const auto& r : rows) {
    w0 = std::max(w0, r[0].size());
    w1 = std::max(w1, r[1].size());
  }
  for (const auto& r : rows) {
    std::string line = r[0] + std::string(w0 - r[0].size() + 2, ' ') + r[1];
    if (!r[2].empty()) line += std::string(w1 - r[1].size() + 2, ' ') + r[2];
    out << line << '\n';
  }
}

void print_json(const json& result) { std::cout << result.dump(2) << '\n'; }

void print_scene_result(const json& result) {
  std::cout << "scene " << result.value("scene", std::string("?"));
  if (result.contains("effective_cycle")) std::cout << ", in effect from cycle " << result["effective_cycle"];
  std::cout << '\n';
  print_params(std::cout, result.value("parameters", json::object()), result.value("units", json::object()));
  for (const auto& note : result.value("notes", json::array())) {
    if (note.is_string()) std::cout << "note: " << note.get<std::string>() << '\n';
  }
  const json verdict = result.value("stability", json::object());
  if (verdict.contains("summary") && verdict["summary"].is_string()) {
    std::cout << "stability: " << verdict["summary"].get<std::string>() << '\n';
  }
  if (!result.value("forced", false)) return;
  std::cerr << "hapticctl: warning: this parameter set is UNSTABLE (loaded with --force)";
  if (verdict.contains("doubling_time_s") && verdict["doubling_time_s"].is_number()) {
    std::cerr << "; the amplitude doubles every " << scalar(verdict["doubling_time_s"]) << " s";
  }
  std::cerr << "; the torque limit still holds\n";
}

}  // namespace detail
}  // namespace hapticctl
