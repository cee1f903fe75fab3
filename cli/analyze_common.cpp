#include "cli/analyze_common.hpp"

#include <cmath>
#include <cstdio>

#include "cli/analyze.hpp"
#include "cli/arguments.hpp"
#include "world/text.hpp"

namespace hapticd::cli {

double period_flag(const std::string& text) {
  return duration_within("--period", text, min_period_s, max_period_s,
                         "a duration from 1 us to 1 s such as 1ms, 250us or 0.001s");
}

std::string fmt(double value) {
  return world::text::format_significant(value, world::text::precision::message);
}

std::string fmt_duration(double seconds) {
  if (seconds >= 1.0) return fmt(seconds) + " s";
  if (seconds >= 1e-3) return fmt(seconds * 1e3) + " ms";
  return fmt(seconds * 1e6) + " us";
}

void Table::print(std::ostream& out) const {
  std::size_t width = 0;
  for (const auto& [key, value] : rows_) width = std::max(width, key.size());
  for (const auto& [key, value] : rows_) {
    out << key << ":" << std::string(width - key.size() + 1, ' ') << value << "\n";
  }
}

void add_analyze_command(CLI::App& app) {
  auto* analyze = app.add_subcommand("analyze", "Offline stability analysis (no daemon needed)");
  analyze->require_subcommand(1);
  add_analyze_integrator(*analyze);
  add_analyze_wall(*analyze);
  add_analyze_critical_stiffness(*analyze);
  add_analyze_passivity(*analyze);
  add_analyze_plane_wall(*analyze);
}

}  // namespace hapticd::cli
