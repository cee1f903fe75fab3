#pragma once
/// \file
/// Named unit conversions. Everything inside hapticd is SI (m, rad, s, kg,
/// N, N*m). The papers mix N-mm, degrees and N-m/deg: convert once, at the
/// edge, with these helpers.

#include <numbers>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::world::units {

inline constexpr double pi = std::numbers::pi;

constexpr double deg_to_rad(double deg) noexcept { return deg * pi / 180.0; }
constexpr double rad_to_deg(double rad) noexcept { return rad * 180.0 / pi; }
constexpr double n_mm_to_n_m(double n_mm) noexcept { return n_mm * 1e-3; }
constexpr double n_m_to_n_mm(double n_m) noexcept { return n_m * 1e3; }
/// Torsional stiffness given per degree (Freudenberg 2.1) to per radian.
constexpr double n_m_per_deg_to_n_m_per_rad(double k) noexcept { return k * 180.0 / pi; }
/// Inertia given as N-m/(deg/s^2) (Freudenberg 2.1) to kg m^2.
constexpr double n_m_per_deg_s2_to_kg_m2(double j) noexcept { return j * 180.0 / pi; }
constexpr double hz_to_rad_per_s(double hz) noexcept { return 2.0 * pi * hz; }
constexpr double rad_per_s_to_hz(double w) noexcept { return w / (2.0 * pi); }

/// Parses a duration with an optional unit suffix: "1ms", "250us", "0.001s",
/// "0.001" (seconds). Returns seconds, or nothing if the text is not a finite
/// number followed by one of s, ms, us.
std::optional<double> parse_duration_s(std::string_view text) noexcept;

/// A duration in the unit that reads best: "250us", "10ms", "1.5s".
std::string format_duration(double seconds);

/// Parses a finite floating-point number; nothing on any trailing text, NaN or Inf.
std::optional<double> parse_finite(std::string_view text) noexcept;

}  // namespace hapticd::world::units
