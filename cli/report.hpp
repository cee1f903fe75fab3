#pragma once
/// \file
/// `hapticctl report accuracy | stability | passivity`: offline studies written as
/// figures (cli/report_figure.hpp) and printed as tables. Long studies show
/// their progress on stderr when it is a terminal and stop cleanly on Ctrl-C
/// (nothing is written then; exit 130).

#include <CLI/CLI.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/study_progress.hpp"

namespace hapticd::cli {

/// Adds `report` with its subcommands accuracy, stability and passivity.
void add_report_command(CLI::App& app);
void add_report_accuracy(CLI::App& report);
void add_report_stability(CLI::App& report);
void add_report_passivity(CLI::App& report);

/// Exit code of a report stopped with Ctrl-C (128 + SIGINT, as a shell reports it).
inline constexpr int exit_interrupted = 130;

/// Column-aligned text for the terminal: columns of numbers right-aligned, text left.
class TextTable {
 public:
  explicit TextTable(std::vector<std::string> header) : header_(std::move(header)) {}
  void row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
  void print(std::ostream& out, const std::string& indent = "  ") const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

/// CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID), seconds.
double thread_cpu_seconds() noexcept;

/// While alive: SIGINT sets a flag instead of ending the process (restored
/// on destruction), and progress() reports to stderr if it is a terminal.
class ReportSession {
 public:
  ReportSession();
  ~ReportSession();
  ReportSession(const ReportSession&) = delete;
  ReportSession& operator=(const ReportSession&) = delete;

  /// A progress sink for a study named `title`: draws "[ 42%] title: stage"
  /// at most ten times a second, and asks the study to stop after Ctrl-C.
  analysis::StudyProgress progress(std::string title);
  /// Clears the progress line.
  void end_progress() const;
  static bool interrupted() noexcept;
  /// "hapticctl: report stopped by Ctrl-C; nothing written" and the exit code.
  int stopped() const;
};

/// The output directory's staged files; UsageError naming --out if it cannot be created.
class StagedFiles;
StagedFiles open_output(const std::string& dir);

/// "1.23e-04" (3 significant digits), "-" for NaN, "inf", "0".
std::string sci(double value);
/// Comma-separated durations ("20us,1ms") or numbers; UsageError naming the flag.
std::vector<double> duration_list(std::string_view flag, const std::string& text);

}  // namespace hapticd::cli
