#pragma once
/// \file
/// Numbers and lists as text, one policy for the whole tree (C locale always,
/// std::to_chars, so a locale never turns 0.5 into "0,5"):
///  - format_number(x): the shortest text that reads back as the same double
///    ("0.1", "250", "1e+06", "1e-300"). For values a person or a program
///    may take back: parameter values, driver ranges, recordings, TOML.
///  - format_significant(x, digits): printf's %.<digits>g, for figures
///    whose last digits are noise. The precisions in use are named below,
///    so that one kind of message keeps one look.
///  - format_fixed(x, decimals): printf's %.<decimals>f, where a fixed
///    number of decimals is the point (pole radii next to 1).
///  - format_quantity(x, unit, digits): a figure with its unit ("46 N s/m").
///  - join(items, separator): "a, b, c".
/// Non-finite values print as "nan", "-nan", "inf", "-inf".

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>

namespace hapticd::world::text {

namespace precision {
/// iostream's default: scene and device messages, notes, server figures ("1e+09", "78.9568").
inline constexpr int message = 6;
/// The stability gate's summaries and limits, the relay tuner ("0.02513", "1234").
inline constexpr int summary = 4;
/// Verdict reasons, sweep labels, bus budgets ("1e+11", "0.35", "125").
inline constexpr int coarse = 3;
/// A parameter echoed back in a description, where 6 digits would merge neighbours.
inline constexpr int parameter = 10;
/// A value after a unit conversion, without its rounding noise (250e-6 s in
/// us prints as 250, not 250.00000000000003): durations, the loopback's values.
inline constexpr int converted = 12;
/// Every digit (figure CSVs): %.17g reads back as the same double.
inline constexpr int all = 17;
}  // namespace precision

std::string format_number(double value);
std::string format_significant(double value, int digits);
std::string format_fixed(double value, int decimals);
std::string format_quantity(double value, std::string_view unit, int digits = precision::message);
/// "0x" and `digits` upper-case hex digits at least: object indices (CiA 301
/// "0x6041"), registers, codes.
std::string format_hex(std::uint32_t value, int digits);
/// format_number(value) appended to `out` (a CSV line), without a temporary.
void append_number(std::string& out, double value);

/// A markdown table cell: a '|' inside (units "kg m^2 | kg", "|F| <= A")
/// escaped so that it does not end the cell.
std::string markdown_cell(std::string_view text);

/// The C library's text for an errno value ("Connection refused").
std::string errno_text(int error);

std::string join(std::span<const std::string> items, std::string_view separator = ", ");
std::string join(std::initializer_list<std::string_view> items, std::string_view separator = ", ");

}  // namespace hapticd::world::text
