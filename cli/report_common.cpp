// Shared pieces of `hapticctl report`: Ctrl-C, progress, text tables.

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <sstream>

#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "world/units.hpp"

namespace hapticd::cli {

namespace {

volatile std::sig_atomic_t interrupt_requested = 0;

void on_report_interrupt(int) { interrupt_requested = 1; }

struct sigaction previous_action {};

}  // namespace

void add_report_command(CLI::App& app) {
  auto* report = app.add_subcommand(
      "report", "Offline studies as figures (PNG via gnuplot, CSV, JSON, .gp) and tables (no daemon needed)");
  report->require_subcommand(1);
  add_report_accuracy(*report);
  add_report_stability(*report);
  add_report_passivity(*report);
}

namespace {
/// A cell that reads as a number (or a placeholder for one): right-aligned.
bool numeric_cell(const std::string& cell) {
  if (cell.empty() || cell == "-" || cell == "inf" || cell == "-inf") return true;
  char* end = nullptr;
  std::strtod(cell.c_str(), &end);
  return end != cell.c_str() && (*end == '\0' || *end == '*' || *end == ' ');
}
}  // namespace

void TextTable::print(std::ostream& out, const std::string& indent) const {
  std::vector<bool> right(header_.size(), true);
  for (const auto& r : rows_) {
    for (std::size_t i = 0; i < r.size() && i < right.size(); ++i) right[i] = right[i] && numeric_cell(r[i]);
  }
  std::vector<std::size_t> width(header_.size(), 0);
  const auto measure = [&](const std::vector<std::string>& cells) {
    for (std::size_t i = 0; i < cells.size() && i < width.size(); ++i)
      width[i] = std::max(width[i], cells[i].size());
  };
  measure(header_);
  for (const auto& r : rows_) measure(r);
  const auto line = [&](const std::vector<std::string>& cells) {
    std::string text = indent;
    for (std::size_t i = 0; i < width.size(); ++i) {
      const std::string cell = i < cells.size() ? cells[i] : "";
      const std::string pad(width[i] - cell.size(), ' ');
      text += (i == 0 ? "" : "  ") + (right[i] ? pad + cell : cell + pad);
    }
    while (!text.empty() && text.back() == ' ') text.pop_back();
    out << text << "\n";
  };
  line(header_);
  for (const auto& r : rows_) line(r);
}

double thread_cpu_seconds() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

ReportSession::ReportSession() {
  interrupt_requested = 0;
  struct sigaction action {};
  action.sa_handler = on_report_interrupt;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: a blocking wait returns EINTR and is retried by its caller
  ::sigaction(SIGINT, &action, &previous_action);
}

ReportSession::~ReportSession() { ::sigaction(SIGINT, &previous_action, nullptr); }

bool ReportSession::interrupted() noexcept { return interrupt_requested != 0; }

analysis::StudyProgress ReportSession::progress(std::string title) {
  const bool terminal = ::isatty(STDERR_FILENO) == 1;
  auto last = std::make_shared<std::chrono::steady_clock::time_point>();
  return analysis::StudyProgress(
      [terminal, title = std::move(title), last](double fraction, const std::string& stage) {
        if (interrupted()) return false;
        if (!terminal) return true;
        const auto now = std::chrono::steady_clock::now();
        if (now - *last < std::chrono::milliseconds(100)) return true;
        *last = now;
        std::string line = "[" + std::to_string(static_cast<int>(100.0 * std::min(1.0, fraction))) + "%] " +
                           title + ": " + stage;
        if (line.size() > 100) line.resize(100);
        std::fprintf(stderr, "\r\033[K%s", line.c_str());
        std::fflush(stderr);
        return true;
      },
      thread_cpu_seconds);
}

void ReportSession::end_progress() const {
  if (::isatty(STDERR_FILENO) == 1) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
}

int ReportSession::stopped() const {
  end_progress();
  std::cerr << "hapticctl: report stopped by Ctrl-C; nothing written\n";
  return exit_interrupted;
}

StagedFiles open_output(const std::string& dir) {
  try {
    return StagedFiles(dir);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
}

std::string sci(double value) {
  if (std::isnan(value)) return "-";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  if (value == 0.0) return "0";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2e", value);
  return buffer;
}

std::vector<double> duration_list(std::string_view flag, const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const auto value = world::units::parse_duration_s(item);
    if (!value || !(*value > 0.0)) {
      throw UsageError(std::string(flag) + ": '" + item +
                       "' is not accepted; expected durations > 0 separated by commas, e.g. 20us,1ms,10ms");
    }
    out.push_back(*value);
  }
  if (out.empty()) throw UsageError(std::string(flag) + ": give at least one duration, e.g. 1ms");
  return out;
}

}  // namespace hapticd::cli
