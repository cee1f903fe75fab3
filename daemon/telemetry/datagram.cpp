#include "daemon/telemetry/datagram.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <span>

namespace hapticd::daemon::telemetry {

namespace {

struct Fixed {
  const char* name;
  Source source;
};
constexpr Fixed before_scene[] = {{"position", Source::position}};
constexpr Fixed after_scene[] = {{"command", Source::command},
                                 {"applied", Source::applied},
                                 {"latency_s", Source::latency},
                                 {"compute_s", Source::compute},
                                 {"flags", Source::flags}};
constexpr Fixed extra[] = {{"cycle", Source::cycle}, {"time_s", Source::time}};

std::optional<Field> find_field(const std::string& name, const std::vector<std::string>& scene_channels) {
  for (const auto& group : {std::span<const Fixed>(before_scene), std::span<const Fixed>(after_scene),
                            std::span<const Fixed>(extra)}) {
    for (const auto& f : group) {
      if (name == f.name) return Field{name, f.source, 0};
    }
  }
  for (std::size_t i = 0; i < scene_channels.size() && i < max_telemetry_channels; ++i) {
    if (scene_channels[i] == name) return Field{name, Source::scene, i};
  }
  return std::nullopt;
}

void append_key(std::string& out, std::string_view key) {
  out += '"';
  for (const char c : key) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      continue;  // names come from the catalog and never hold control characters
    } else {
      out += c;
    }
  }
  out += "\":";
}

void append_number(std::string& out, double value, std::uint64_t& non_finite) {
  if (!std::isfinite(value)) {
    ++non_finite;
    out += "null";
    return;
  }
  char buffer[32];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, ec == std::errc{} ? end : buffer);
}

void append_integer(std::string& out, std::uint64_t value) {
  char buffer[24];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, ec == std::errc{} ? end : buffer);
}

double value_of(const TelemetrySample& s, const Field& f) {
  switch (f.source) {
    case Source::position:
      return s.position;
    case Source::command:
      return s.command;
    case Source::applied:
      return s.applied;
    case Source::latency:
      return s.latency_s;
    case Source::compute:
      return s.compute_s;
    case Source::time:
      return s.time_s;
    case Source::scene:
      return f.index < s.channel_count ? s.channels[f.index] : std::nan("");
    case Source::flags:
    case Source::cycle:
      break;
  }
  return 0.0;
}

}  // namespace

std::vector<std::string> default_channels(const std::vector<std::string>& scene_channels) {
  std::vector<std::string> out;
  for (const auto& f : before_scene) out.emplace_back(f.name);
  for (std::size_t i = 0; i < scene_channels.size() && i < max_telemetry_channels; ++i)
    out.push_back(scene_channels[i]);
  for (const auto& f : after_scene) out.emplace_back(f.name);
  return out;
}

std::vector<std::string> available_channels(const std::vector<std::string>& scene_channels) {
  auto out = default_channels(scene_channels);
  for (const auto& f : extra) out.emplace_back(f.name);
  return out;
}

std::optional<std::string> unknown_channel(const std::vector<std::string>& wanted,
                                           const std::vector<std::string>& scene_channels) {
  for (const auto& name : wanted) {
    if (!find_field(name, scene_channels)) return name;
  }
  return std::nullopt;
}

Layout make_layout(const std::vector<std::string>& wanted, const std::vector<std::string>& scene_channels) {
  const auto names = wanted.empty() ? default_channels(scene_channels) : wanted;
  Layout layout;
  for (const auto& name : names) {
    if (auto field = find_field(name, scene_channels)) layout.push_back(std::move(*field));
  }
  return layout;
}

std::string exact_seconds(std::uint64_t cycle, std::int64_t period_ns) {
  // cycle * period_ns would overflow 64 bits after 584 years of 1 ms cycles;
  // split the cycle at 1e9 so the product never wraps into a wrong time
  // (exact while period_ns < 1.8e10, and periods are at most 10 ms).
  constexpr std::uint64_t giga = 1'000'000'000;
  const auto p = static_cast<std::uint64_t>(period_ns);
  const std::uint64_t low = (cycle % giga) * p;
  const std::uint64_t whole = (cycle / giga) * p + low / giga;
  std::uint64_t fraction = low % giga;
  std::string out;
  append_integer(out, whole);
  if (fraction != 0) {
    char digits[10] = "000000000";
    for (int i = 8; i >= 0; --i) {
      digits[i] = static_cast<char>('0' + fraction % 10);
      fraction /= 10;
    }
    std::size_t length = 9;
    while (digits[length - 1] == '0') --length;  // fraction != 0: stops at a digit
    out += '.';
    out.append(digits, length);
  }
  return out;
}

void append_object(std::string& out, const TelemetrySample& sample, const Layout& layout,
                   std::string_view prefix, std::int64_t period_ns, std::uint64_t& non_finite) {
  out += "{\"t\":";
  out += exact_seconds(sample.cycle, period_ns);
  out += ',';
  append_key(out, prefix);
  out += '{';
  bool first = true;
  for (const auto& field : layout) {
    if (!first) out += ',';
    first = false;
    append_key(out, field.name);
    if (field.source == Source::cycle) {
      append_integer(out, sample.cycle);
    } else if (field.source == Source::flags) {
      append_integer(out, sample.flags);
    } else {
      append_number(out, value_of(sample, field), non_finite);
    }
  }
  out += "}}";
}

bool valid_prefix(std::string_view prefix) noexcept {
  if (prefix.empty() || prefix.size() > 32) return false;
  return std::all_of(prefix.begin(), prefix.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

}  // namespace hapticd::daemon::telemetry
