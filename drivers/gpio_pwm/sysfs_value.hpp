#pragma once
/// \file
/// The text of an unsigned sysfs attribute (PWM period/duty_cycle/enable,
/// counter count/ceiling): decimal digits and a trailing newline, as the
/// kernel prints them with "%llu\n" / "%u\n". Pure, allocation-free: used on
/// the RT path with stack buffers.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace hapticd::drivers::gpio_pwm {

/// Enough for UINT64_MAX (20 digits) and the newline.
inline constexpr std::size_t sysfs_u64_text_size = 21;

/// Parses leading decimal digits up to an optional "\n" (what follows the
/// first newline is ignored: a plain file overwritten at offset 0 with a
/// shorter value keeps the old tail). Nothing else is accepted: no sign, no
/// spaces, no empty text, no overflow.
std::optional<std::uint64_t> parse_sysfs_u64(std::string_view text) noexcept;

/// Writes "<value>\n" into `out` (at least sysfs_u64_text_size bytes);
/// returns the length, or 0 if `out` is too small.
std::size_t format_sysfs_u64(std::uint64_t value, std::span<char> out) noexcept;

}  // namespace hapticd::drivers::gpio_pwm
