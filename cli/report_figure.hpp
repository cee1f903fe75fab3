#pragma once
/// \file
/// Figures of `hapticctl report`: each is written as NAME.csv (the data),
/// NAME.json (the same data with its meaning), NAME.gp (a gnuplot script that
/// redraws it from the CSV: `gnuplot NAME.gp` in the output directory) and
/// NAME.png, drawn by gnuplot's pngcairo terminal when gnuplot is on PATH.
/// Every file goes to a temporary name first and is renamed into place only
/// when the whole report is complete, so an interrupted report leaves nothing
/// half-written.

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticd::cli {

/// One cell: a number (non-finite allowed: "nan", "inf" in CSV, null in JSON), text or a flag.
using Cell = std::variant<double, std::string, bool>;

struct DataTable {
  std::vector<std::string> columns;
  std::vector<std::vector<Cell>> rows;

  /// 1-based index of a column (gnuplot's $N); throws std::logic_error if absent.
  std::size_t column(std::string_view name) const;
  /// Header line, then one line per row; numbers with 17 significant digits, flags 1/0.
  std::string csv() const;
  /// {"columns": [...], "rows": [[...], ...]}.
  nlohmann::json json() const;
};

/// A condition on a row: text column equal to a value, or a numeric column equal to a number.
struct Match {
  std::string column;
  Cell value;
};

/// One drawn series: column x against column y over the rows that match.
struct Curve {
  std::string title;  ///< legend entry; empty: no entry
  std::vector<Match> where;
  std::string x;
  std::string y;
  std::string style;    ///< gnuplot "with ..." text, e.g. "linespoints pt 7 lc rgb '#1b9e77'"
  std::string y2 = {};  ///< a second y column (filledcurves between y and y2)
};

struct Axis {
  std::string label;  ///< with the unit, e.g. "CPU time per simulated second (s/s)"
  bool log = false;
  std::string range;  ///< gnuplot range, e.g. "[1e-16:100]"; empty: automatic
};

struct Figure {
  std::string name;   ///< file stem
  std::string title;  ///< may hold line breaks
  Axis x;
  Axis y;
  DataTable data;
  std::vector<Curve> curves;
  std::vector<std::string> decorations;            ///< gnuplot commands before `plot` (limits, labels)
  nlohmann::json meta = nlohmann::json::object();  ///< written into NAME.json beside the data
  std::string key = "outside below center horizontal maxcols 3";
  std::string command = "hapticctl report";  ///< what wrote it (named in the .gp script)
};

/// A colour per method or series name, the same in every figure.
std::string colour_for(std::string_view name);
/// "text" for gnuplot, line breaks as \n (a title over several lines).
std::string gnuplot_text(std::string_view text);
/// 'text' quoted for gnuplot (a ' inside becomes '').
std::string gnuplot_quote(std::string_view text);

/// Files of one report under temporary names, renamed into place by commit().
class StagedFiles {
 public:
  /// Creates dir if needed; throws std::runtime_error naming the directory if it cannot.
  explicit StagedFiles(std::filesystem::path dir);
  ~StagedFiles();
  StagedFiles(const StagedFiles&) = delete;
  StagedFiles& operator=(const StagedFiles&) = delete;

  /// Writes content to the temporary name of dir/name; returns that path.
  std::filesystem::path stage(const std::string& name, std::string_view content);
  /// The temporary path for dir/name, to be written by another program.
  std::filesystem::path reserve(const std::string& name);
  /// Renames every staged file that exists to its final name.
  std::vector<std::filesystem::path> commit();
  const std::filesystem::path& dir() const noexcept { return dir_; }

 private:
  std::filesystem::path dir_;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> staged_;  ///< temporary, final
  bool committed_ = false;
};

/// Writes figures into a StagedFiles set and draws them with gnuplot.
class FigureWriter {
 public:
  explicit FigureWriter(StagedFiles& files) : files_(files) {}

  /// NAME.csv, NAME.json, NAME.gp; NAME.png if gnuplot is found and succeeds.
  void write(const Figure& figure);
  /// The gnuplot script for the figure, reading `data` and writing `output`
  /// unless those variables are already set (gnuplot -e).
  static std::string script(const Figure& figure);

  /// One line per figure gnuplot could not draw (with gnuplot's message).
  const std::vector<std::string>& failures() const noexcept { return failures_; }
  /// Tells stderr what was not drawn: gnuplot missing (with what to do in
  /// `dir`), then each failure.
  void report_problems(const std::filesystem::path& dir) const;

 private:
  StagedFiles& files_;
  bool missing_ = false;
  std::vector<std::string> failures_;
};

}  // namespace hapticd::cli
