#pragma once
/// \file
/// Parsing of numeric flags with messages that name the flag, the bad value
/// and what is accepted. All values SI; durations take s, ms or us.

#include <optional>
#include <string>
#include <string_view>

namespace hapticd::cli {

/// Finite number > 0. Throws UsageError("--mass: '-1' is not accepted; expected a number > 0 (kg)").
double positive_number(std::string_view flag, const std::string& text, std::string_view unit);
/// Finite number >= 0.
double non_negative_number(std::string_view flag, const std::string& text, std::string_view unit);
/// Duration > 0 with optional s/ms/us suffix, in seconds.
double positive_duration(std::string_view flag, const std::string& text);
/// Duration >= 0 with optional s/ms/us suffix, in seconds.
double non_negative_duration(std::string_view flag, const std::string& text);
/// Duration in [min_s, max_s] (to a relative 1e-12, so "1us" and "0.001ms"
/// both reach 1e-6) with optional s/ms/us suffix, in seconds; `expected`
/// says what is accepted ("a duration from 1 us to 1 s such as 1ms").
double duration_within(std::string_view flag, const std::string& text, double min_s, double max_s,
                       std::string_view expected);
/// Whole number in [min, max].
int whole_number(std::string_view flag, const std::string& text, int min, int max);

/// The same for optional flags: nothing when the flag was not given (text empty).
std::optional<double> optional_positive(std::string_view flag, const std::string& text,
                                        std::string_view unit);
std::optional<double> optional_non_negative(std::string_view flag, const std::string& text,
                                            std::string_view unit);

}  // namespace hapticd::cli
