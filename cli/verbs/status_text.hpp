#pragma once
/// \file
/// `hapticctl status` and `hapticctl stats` for a person: the essentials of
/// the daemon's `status` and `stats` results (docs/protocol.md) on one
/// screen, values with their units, like `systemctl status`. Pure: JSON in,
/// text out; a member the daemon did not send is left out, never guessed.

#include <string>

#include <nlohmann/json.hpp>

namespace hapticctl::detail {

/// The status screen: state (and why, when faulted), device, scene with its
/// parameters and units, stability, real-time set-up, recording and, when
/// `stats` is an object, loop latency and overruns.
std::string status_text(const nlohmann::json& status, const nlohmann::json& stats);

/// The stats screen: loop timing (latency and compute percentiles, overruns),
/// errors, the device's counters, the recorder and the control plane.
std::string stats_text(const nlohmann::json& stats);

/// "22 us", "1.44 ms", "2.5 s" from microseconds; "-" for a non-number.
std::string microseconds_text(const nlohmann::json& us);

/// "latency p50 22 us, p99 43 us, max 290 us" from a stats histogram
/// ({"count", "p50_us", ...}); "no samples yet" when empty.
std::string histogram_text(const nlohmann::json& histogram, bool with_tail);

}  // namespace hapticctl::detail
