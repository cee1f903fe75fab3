#pragma once
/// \file
/// Telemetry samples as PlotJuggler's UDP server reads them (its JSON parser,
/// plotjuggler_app/nlohmann_parsers.cpp, and plugin DataStreamUDP):
/// - one JSON object per datagram, or a top-level array of objects, each
///   element a sample of its own (a batch; PlotJuggler versions before the
///   batch support flatten an array to "[0]/..." series and lose the time);
/// - nested objects become "/a/b" series: {"t":..., "hapticd":{"position":...}}
///   gives /hapticd/position;
/// - "use field as timestamp" takes the named top-level number; one message
///   without it switches the parser to arrival time for good: every object
///   carries "t";
/// - a parse error stops PlotJuggler's server, and nlohmann's parser refuses
///   NaN and Infinity: a non-finite value is sent as null (a point the
///   parser skips) and counted;
/// - one version of the plugin reads datagrams into a 2048-byte buffer: no
///   datagram is longer (max_datagram_bytes).
/// t is the cycle times the period, printed exactly from integer
/// nanoseconds (the world's time, not the wall clock's).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/telemetry.hpp"

namespace hapticd::daemon::telemetry {

inline constexpr std::size_t max_datagram_bytes = 2048;

/// Where a field's value comes from in a TelemetrySample.
enum class Source : std::uint8_t { position, command, applied, latency, compute, flags, cycle, time, scene };

struct Field {
  std::string name;
  Source source = Source::position;
  std::size_t index = 0;  ///< Source::scene: index into TelemetrySample::channels
};
/// The fields of one object, in order.
using Layout = std::vector<Field>;

/// Every channel name a sample of a scene with these channels offers, in the
/// recording's column order (position, the scene's, command, applied,
/// latency_s, compute_s, flags), then cycle and time_s.
std::vector<std::string> available_channels(const std::vector<std::string>& scene_channels);
/// The channels sent when none are named: the recording's columns.
std::vector<std::string> default_channels(const std::vector<std::string>& scene_channels);
/// The first of `wanted` the scene does not offer, if any.
std::optional<std::string> unknown_channel(const std::vector<std::string>& wanted,
                                           const std::vector<std::string>& scene_channels);
/// The layout for `wanted` (empty: default_channels) on a scene; names the
/// scene does not offer are left out (a later scene may lack a channel).
Layout make_layout(const std::vector<std::string>& wanted, const std::vector<std::string>& scene_channels);

/// Appends {"t":T,"<prefix>":{fields}} to out; counts non-finite values
/// (written as null) in non_finite.
void append_object(std::string& out, const TelemetrySample& sample, const Layout& layout,
                   std::string_view prefix, std::int64_t period_ns, std::uint64_t& non_finite);
/// The exact decimal of cycle * period_ns nanoseconds in seconds ("12.345").
std::string exact_seconds(std::uint64_t cycle, std::int64_t period_ns);

/// A prefix is 1 to 32 of [A-Za-z0-9_-] (a JSON key and a PlotJuggler path element).
bool valid_prefix(std::string_view prefix) noexcept;

}  // namespace hapticd::daemon::telemetry
