#pragma once
// Shared output helpers for the analyze subcommands.

#include <CLI/CLI.hpp>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace hapticd::cli {

/// Every analysis takes sampling periods from 1 us to 1 s: shorter or longer
/// ones are typos (1e-300, 1e308), not haptic loops.
inline constexpr double min_period_s = 1e-6;
inline constexpr double max_period_s = 1.0;
/// --period within that range; a UsageError naming it otherwise.
double period_flag(const std::string& text);

/// Numbers with 6 significant digits, for humans (--json prints full precision).
std::string fmt(double value);
/// 0.001 -> "1 ms", 2.5e-4 -> "250 us".
std::string fmt_duration(double seconds);

/// "key: value" lines with the values aligned.
class Table {
 public:
  void row(std::string key, std::string value) { rows_.emplace_back(std::move(key), std::move(value)); }
  void print(std::ostream& out) const;

 private:
  std::vector<std::pair<std::string, std::string>> rows_;
};

void add_analyze_wall(CLI::App& analyze);
void add_analyze_integrator(CLI::App& analyze);
void add_analyze_critical_stiffness(CLI::App& analyze);
void add_analyze_passivity(CLI::App& analyze);
void add_analyze_plane_wall(CLI::App& analyze);

}  // namespace hapticd::cli
