#include "cli/report_figure.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "world/text.hpp"

extern char** environ;

namespace hapticd::cli {

namespace {

std::string number_text(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  return world::text::format_significant(x, world::text::precision::all);
}

std::string csv_field(const Cell& cell) {
  if (const double* x = std::get_if<double>(&cell)) return number_text(*x);
  if (const bool* b = std::get_if<bool>(&cell)) return *b ? "1" : "0";
  const std::string& s = std::get<std::string>(cell);
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (const char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

nlohmann::json json_cell(const Cell& cell) {
  if (const double* x = std::get_if<double>(&cell)) return std::isfinite(*x) ? nlohmann::json(*x) : nullptr;
  if (const bool* b = std::get_if<bool>(&cell)) return *b;
  return std::get<std::string>(cell);
}

std::string temporary_name(const std::filesystem::path& final_path) {
  return final_path.filename().string() + ".part-" + std::to_string(::getpid());
}

/// Runs gnuplot; nothing on success, else why not. ENOENT sets `missing`.
std::optional<std::string> run_gnuplot(const std::string& assignments, const std::filesystem::path& script,
                                       const std::filesystem::path& log, bool& missing) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string program = "gnuplot";
  std::string e = "-e";
  std::string script_text = script.string();
  char* argv[] = {program.data(), e.data(), const_cast<char*>(assignments.c_str()), script_text.data(),
                  nullptr};
  pid_t pid = -1;
  const int spawned = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    if (spawned == ENOENT) missing = true;
    return "cannot start gnuplot: " + std::error_code(spawned, std::generic_category()).message();
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return std::nullopt;
  std::ifstream in(log);
  std::string message((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
  if (WIFSIGNALED(status)) return "gnuplot stopped by signal " + std::to_string(WTERMSIG(status));
  return "gnuplot failed: " +
         (message.empty() ? std::string("exit ") + std::to_string(WEXITSTATUS(status)) : message);
}

}  // namespace

std::size_t DataTable::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i + 1;
  }
  throw std::logic_error("figure data has no column '" + std::string(name) + "'");
}

std::string DataTable::csv() const {
  std::string out;
  for (std::size_t i = 0; i < columns.size(); ++i) out += (i ? "," : "") + columns[i];
  out += '\n';
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) out += (i ? "," : "") + csv_field(row[i]);
    out += '\n';
  }
  return out;
}

nlohmann::json DataTable::json() const {
  nlohmann::json rows_json = nlohmann::json::array();
  for (const auto& row : rows) {
    nlohmann::json r = nlohmann::json::array();
    for (const Cell& cell : row) r.push_back(json_cell(cell));
    rows_json.push_back(std::move(r));
  }
  return {{"columns", columns}, {"rows", std::move(rows_json)}};
}

std::string colour_for(std::string_view name) {
  struct Entry {
    std::string_view prefix;
    std::string_view colour;
  };
  static constexpr Entry palette[] = {
      {"forward-euler", "#d95f02"}, {"semi-implicit-euler", "#7570b3"},
      {"trapezoid", "#1b9e77"},     {"rk4", "#e7298a"},
      {"exact", "#2166ac"},         {"sampled-wall", "#e6ab02"},
      {"odeint-rk4", "#a6761d"},    {"odeint-dopri5", "#555555"},
  };
  for (const Entry& e : palette) {
    if (name == e.prefix) return std::string(e.colour);
  }
  // Anything else: a stable colour from the name.
  static constexpr std::string_view others[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a",
                                                "#66a61e", "#e6ab02", "#a6761d", "#666666"};
  std::size_t hash = 0;
  for (const char c : name) hash = hash * 31 + static_cast<unsigned char>(c);
  return std::string(others[hash % 8]);
}

std::string gnuplot_text(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '\n') {
      out += "\\n";
    } else {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
  }
  return out + "\"";
}

std::string gnuplot_quote(std::string_view text) {
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

StagedFiles::StagedFiles(std::filesystem::path dir) : dir_(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec || !std::filesystem::is_directory(dir_)) {
    throw std::runtime_error("--out: cannot create directory '" + dir_.string() +
                             "': " + (ec ? ec.message() : std::string("not a directory")));
  }
}

StagedFiles::~StagedFiles() {
  if (committed_) return;
  for (const auto& [temporary, final_path] : staged_) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
  }
}

std::filesystem::path StagedFiles::reserve(const std::string& name) {
  const std::filesystem::path final_path = dir_ / name;
  std::filesystem::path temporary = dir_ / temporary_name(final_path);
  staged_.emplace_back(temporary, final_path);
  return temporary;
}

std::filesystem::path StagedFiles::stage(const std::string& name, std::string_view content) {
  std::filesystem::path temporary = reserve(name);
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  out.write(content.data(), static_cast<std::streamsize>(content.size()));
  out.close();
  if (!out) throw std::runtime_error("cannot write '" + temporary.string() + "'");
  return temporary;
}

std::vector<std::filesystem::path> StagedFiles::commit() {
  std::vector<std::filesystem::path> written;
  for (const auto& [temporary, final_path] : staged_) {
    if (!std::filesystem::exists(temporary)) continue;  // e.g. a PNG gnuplot did not draw
    std::filesystem::rename(temporary, final_path);
    written.push_back(final_path);
  }
  committed_ = true;
  return written;
}

std::string FigureWriter::script(const Figure& f) {
  std::ostringstream s;
  for (std::size_t at = 0; at <= f.title.size();) {
    const std::size_t end = std::min(f.title.find('\n', at), f.title.size());
    s << "# " << f.title.substr(at, end - at) << "\n";
    at = end + 1;
  }
  s << "# Written by `" << f.command << "`. Redraw in this directory with: gnuplot " << f.name << ".gp\n"
    << "# Data: " << f.name << ".csv (the same rows, with units, in " << f.name << ".json).\n"
    << "if (!exists(\"data\")) data = " << gnuplot_quote(f.name + ".csv") << "\n"
    << "if (!exists(\"output\")) output = " << gnuplot_quote(f.name + ".png") << "\n"
    << "set datafile separator comma\n"
    << "set terminal pngcairo size 1200,760 enhanced font 'Sans,11'\n"
    << "set output output\n"
    << "set title " << gnuplot_text(f.title) << " noenhanced\n"
    << "set xlabel " << gnuplot_quote(f.x.label) << "\n"
    << "set ylabel " << gnuplot_quote(f.y.label) << "\n"
    << "set grid xtics ytics mxtics mytics lc rgb '#e0e0e0'\n"
    << "set key " << f.key << " spacing 1.1\n";
  const auto axis = [&s](const Axis& a, char name) {
    if (a.log) s << "set logscale " << name << " 10\nset format " << name << " '10^{%L}'\n";
    if (!a.range.empty()) s << "set " << name << "range " << a.range << "\n";
  };
  axis(f.x, 'x');
  axis(f.y, 'y');
  for (const std::string& d : f.decorations) s << d << "\n";
  s << "plot ";
  for (std::size_t i = 0; i < f.curves.size(); ++i) {
    const Curve& c = f.curves[i];
    std::string condition;
    for (const Match& m : c.where) {
      if (!condition.empty()) condition += " && ";
      const std::size_t col = f.data.column(m.column);
      if (const std::string* text = std::get_if<std::string>(&m.value)) {
        condition += "strcol(" + std::to_string(col) + ") eq \"" + *text + "\"";
      } else if (const bool* flag = std::get_if<bool>(&m.value)) {
        condition += "$" + std::to_string(col) + " == " + (*flag ? "1" : "0");
      } else {
        condition += "$" + std::to_string(col) + " == " + number_text(std::get<double>(m.value));
      }
    }
    const std::string x = "$" + std::to_string(f.data.column(c.x));
    std::string y = "($" + std::to_string(f.data.column(c.y)) + ")";
    if (!c.y2.empty()) y += ":($" + std::to_string(f.data.column(c.y2)) + ")";
    s << (i ? ", \\\n     " : "") << (i ? "''" : "data") << " skip 1 using ("
      << (condition.empty() ? x : "(" + condition + ") ? " + x + " : NaN") << "):" << y << " with " << c.style
      << " "
      << (c.title.empty() ? std::string("notitle") : "title " + gnuplot_quote(c.title) + " noenhanced");
  }
  s << "\n";
  return s.str();
}

void FigureWriter::write(const Figure& f) {
  const std::filesystem::path csv = files_.stage(f.name + ".csv", f.data.csv());
  nlohmann::json json = f.meta;
  json["figure"] = f.title;
  json["x"] = f.x.label;
  json["y"] = f.y.label;
  json["data"] = f.data.json();
  files_.stage(f.name + ".json", json.dump(1) + "\n");
  const std::filesystem::path gp = files_.stage(f.name + ".gp", script(f));
  if (missing_) return;
  const std::filesystem::path png = files_.reserve(f.name + ".png");
  const std::filesystem::path log = files_.reserve(f.name + ".gnuplot-log");
  const std::string assignments =
      "data=" + gnuplot_quote(csv.string()) + "; output=" + gnuplot_quote(png.string());
  if (const auto error = run_gnuplot(assignments, gp, log, missing_)) {
    std::error_code ignored;
    std::filesystem::remove(png, ignored);
    if (!missing_) failures_.push_back(f.name + ".png: " + *error);
  }
  std::error_code ignored;
  std::filesystem::remove(log, ignored);
}

void FigureWriter::report_problems(const std::filesystem::path& dir) const {
  if (missing_) {
    std::cerr
        << "hapticctl: gnuplot not found on PATH: wrote the data (.csv, .json) and the scripts (.gp) but no "
           "PNG; install gnuplot-nox and run `gnuplot NAME.gp` in "
        << dir.string() << "\n";
  }
  for (const std::string& failure : failures_) std::cerr << "hapticctl: " << failure << "\n";
}

}  // namespace hapticd::cli
