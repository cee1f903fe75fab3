// `hapticctl report` end to end: the real binary writes the figures; the
// tests read the data behind them back and check the numbers against the
// analytic curves, and check what happens without gnuplot and on Ctrl-C.
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "support.hpp"

namespace hapticd::e2e::report_cli_test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

struct Csv {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
  std::size_t at(const std::string& name) const {
    for (std::size_t i = 0; i < columns.size(); ++i) {
      if (columns[i] == name) return i;
    }
    throw std::runtime_error("no column " + name);
  }
  double number(std::size_t row, const std::string& name) const { return std::stod(rows[row][at(name)]); }
  const std::string& text(std::size_t row, const std::string& name) const { return rows[row][at(name)]; }
};

Csv read_csv(const fs::path& file) {
  std::ifstream in(file);
  Csv csv;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
    if (header) {
      csv.columns = cells;
      header = false;
    } else {
      csv.rows.push_back(cells);
    }
  }
  return csv;
}

bool is_png(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && std::string(magic + 1, 3) == "PNG" && fs::file_size(file) > 10000;
}

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  return out;
}

/// x |sin x| at its last peak within one period (tan x = -x).
double last_sine_peak() {
  double x = 4.9;
  for (int i = 0; i < 50; ++i) x -= (std::tan(x) + x) / (1.0 / (std::cos(x) * std::cos(x)) + 1.0);
  return x * std::abs(std::sin(x));
}

TEST(ReportAccuracyCli, FigureDataFollowTheDerivedCurves) {
  TempDir dir;
  const auto r =
      run(hapticctl_binary(),
          {"report", "accuracy", "--quick", "--scene", "spring-wheel", "--out", dir.path.string(), "--json"},
          120s);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "progress drawn on a stderr that is not a terminal";
  const auto study = nlohmann::json::parse(r.out);
  std::cout << "report accuracy --quick --scene spring-wheel: " << study["elapsed_s"].get<double>() << " s\n";

  // Figure 3: error against w_n T over one natural period, undamped wheel:
  // pi h, h/2, 4.8145 h^2/12, 4.8145 h^4/120 where the leading term rules.
  const double peak = last_sine_peak();
  const std::map<std::string, std::pair<int, double>> derived{{"forward-euler", {1, std::numbers::pi}},
                                                              {"semi-implicit-euler", {1, 0.5}},
                                                              {"trapezoid", {2, peak / 12}},
                                                              {"rk4", {4, peak / 120}}};
  const Csv sweep = read_csv(dir.path / "accuracy_error_vs_wnt_spring-wheel.csv");
  int checked = 0;
  for (std::size_t i = 0; i < sweep.rows.size(); ++i) {
    const auto it = derived.find(sweep.text(i, "method"));
    const double h = sweep.number(i, "wn_t");
    if (it == derived.end() || h > 0.02) continue;
    const double expected = it->second.second * std::pow(h, it->second.first);
    if (expected < 1e-10) continue;  // rk4 below here meets rounding
    EXPECT_NEAR(sweep.number(i, "error") / expected, 1.0, 0.04) << it->first << " h=" << h;
    EXPECT_NEAR(sweep.number(i, "predicted") / expected, 1.0, 1e-9) << it->first << " h=" << h;
    ++checked;
  }
  EXPECT_GE(checked, 15);
  // Stability limits drawn on the figure: 2 (semi-implicit Euler), 2 sqrt2 (RK4).
  for (std::size_t i = 0; i < sweep.rows.size(); ++i) {
    if (sweep.text(i, "method") == "semi-implicit-euler") {
      EXPECT_NEAR(sweep.number(i, "stability_limit"), 2.0, 1e-9);
    }
    if (sweep.text(i, "method") == "rk4") {
      EXPECT_NEAR(sweep.number(i, "stability_limit"), 2 * std::sqrt(2.0), 1e-9);
    }
  }

  // Figure 1: Odeint's RK4 at step T is world's rk4 (same error); dopri5 within 4x its tolerance over 1 s.
  const Csv work = read_csv(dir.path / "accuracy_work_precision_spring-wheel.csv");
  std::map<std::pair<std::string, std::string>, double> error_at;
  for (std::size_t i = 0; i < work.rows.size(); ++i) {
    if (work.number(i, "duration_s") != 10.0) continue;
    error_at[{work.text(i, "method"), work.text(i, "period_s")}] = work.number(i, "error");
    EXPECT_GT(work.number(i, "cpu_s_per_simulated_s"), 0.0);
  }
  for (const char* t : {"0.001", "0.01"}) {
    EXPECT_NEAR(error_at.at({"odeint-rk4", t}) / error_at.at({"rk4", t}), 1.0, 1e-4) << t;
  }
  for (std::size_t i = 0; i < work.rows.size(); ++i) {
    if (work.text(i, "method") != "odeint-dopri5" || work.number(i, "duration_s") != 1.0) continue;
    EXPECT_LT(work.number(i, "error"), 4 * work.number(i, "tolerance"));
  }
  // Figure 2 at the device period: the running maximum never falls.
  const Csv growth = read_csv(dir.path / "accuracy_error_growth_spring-wheel.csv");
  for (std::size_t i = 1; i < growth.rows.size(); ++i) {
    if (growth.text(i, "series") != growth.text(i - 1, "series")) continue;
    EXPECT_GE(growth.number(i, "error"), growth.number(i - 1, "error"));
  }
  // Every figure: data, JSON, script; PNG when gnuplot is installed; no temporaries.
  const bool gnuplot = std::system("command -v gnuplot >/dev/null 2>&1") == 0;
  for (const char* figure : {"accuracy_work_precision_spring-wheel", "accuracy_error_growth_spring-wheel",
                             "accuracy_error_vs_wnt_spring-wheel"}) {
    const auto json = nlohmann::json::parse(std::ifstream(dir.path / (std::string(figure) + ".json")));
    EXPECT_FALSE(json["data"]["rows"].empty()) << figure;
    if (gnuplot) {
      EXPECT_TRUE(is_png(dir.path / (std::string(figure) + ".png"))) << figure;
    }
  }
  for (const auto& name : names_in(dir.path)) EXPECT_EQ(name.find(".part-"), std::string::npos) << name;
}

TEST(ReportAccuracyCli, WithoutGnuplotWritesDataAndScripts) {
  TempDir dir;
  const char* saved = std::getenv("PATH");
  const std::string path = saved ? saved : "";
  ::setenv("PATH", (dir.path / "no-such-bin").c_str(), 1);
  const auto r =
      run(hapticctl_binary(),
          {"report", "accuracy", "--quick", "--scene", "wall", "--out", (dir.path / "out").string()}, 120s);
  ::setenv("PATH", path.c_str(), 1);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gnuplot not found"), std::string::npos) << r.err;
  for (const char* ext : {".csv", ".json", ".gp"}) {
    EXPECT_TRUE(fs::exists(dir.path / "out" / (std::string("accuracy_work_precision_wall") + ext))) << ext;
  }
  EXPECT_FALSE(fs::exists(dir.path / "out" / "accuracy_work_precision_wall.png"));
  for (const auto& name : names_in(dir.path / "out"))
    EXPECT_EQ(name.find(".part-"), std::string::npos) << name;
}

/// Reads what the child wrote to the pty until `done(text)` holds, the child
/// closed it, or `limit` passed; returns everything read.
template <class Done>
std::string read_pty_until(int master, std::chrono::milliseconds limit, Done done) {
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!done(text)) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{master, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
    char chunk[512];
    const ssize_t n = ::read(master, chunk, sizeof chunk);
    if (n <= 0) break;  // EIO: the child closed its side
    text.append(chunk, static_cast<std::size_t>(n));
  }
  return text;
}

// The report runs on a pseudo-terminal, so it draws its progress line; the
// Ctrl-C comes once the first line says the study is under way (a
// handshake, not a guessed sleep), well inside the full study.
TEST(ReportAccuracyCli, CtrlCLeavesNothingBehind) {
  TempDir dir;
  const fs::path out = dir.path / "out";
  int master = -1;
  const pid_t pid = ::forkpty(&master, nullptr, nullptr, nullptr);
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string program = hapticctl_binary().string();
    const std::string out_text = out.string();
    execl(program.c_str(), program.c_str(), "report", "accuracy", "--out", out_text.c_str(), nullptr);
    _exit(127);
  }
  const std::string started = read_pty_until(master, 60s, [](const std::string& text) {
    return text.find("%] report accuracy: ") != std::string::npos;
  });
  ::kill(pid, SIGINT);
  const std::string rest = read_pty_until(master, 30s, [](const std::string& text) {
    return text.find("stopped by Ctrl-C") != std::string::npos;
  });
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (::waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      FAIL() << "hapticctl did not stop on SIGINT";
    }
    (void)read_pty_until(master, 10ms, [](const std::string&) { return false; });  // keep the pty drained
  }
  ::close(master);
  ASSERT_NE(started.find("%] report accuracy: "), std::string::npos) << "no progress line: " << started;
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  EXPECT_NE(rest.find("stopped by Ctrl-C"), std::string::npos) << rest;
  EXPECT_TRUE(names_in(out).empty());
}

TEST(ReportAccuracyCli, BadArgumentsAreUsageErrors) {
  const auto scene = run(hapticctl_binary(), {"report", "accuracy", "--scene", "wheel"});
  EXPECT_EQ(scene.exit_code, 2);
  EXPECT_NE(scene.err.find("--scene: 'wheel' is not accepted"), std::string::npos) << scene.err;
  const auto ambiguous = run(hapticctl_binary(), {"report", "accuracy", "--stiffness", "10"});
  EXPECT_EQ(ambiguous.exit_code, 2);
  EXPECT_NE(ambiguous.err.find("exactly one --scene"), std::string::npos) << ambiguous.err;
  const auto wrong = run(hapticctl_binary(), {"report", "accuracy", "--scene", "wall", "--inertia", "1"});
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("--inertia: not a parameter of wall"), std::string::npos) << wrong.err;
}

// The test suite runs the sweep: any case where analysis, run and gate
// disagree fails here (hapticctl exits 1 and lists it first).
TEST(ReportStabilityCli, QuickSweepHasNoDisagreementAndTheMapsMatchThePapers) {
  TempDir dir;
  const auto r =
      run(hapticctl_binary(), {"report", "stability", "--quick", "--out", dir.path.string(), "--json"}, 120s);
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out.substr(0, 2000);
  const auto result = nlohmann::json::parse(r.out);
  std::cout << "report stability --quick: " << result["cases"].get<int>() << " cases, sweep "
            << result["sweep_seconds"].get<double>() << " s, report " << result["elapsed_s"].get<double>()
            << " s\n";
  EXPECT_EQ(result["disagreements"].get<int>(), 0);
  EXPECT_NEAR(result["wall_maxima"][1]["alpha_max"].get<double>(), 0.144469, 1e-6);
  EXPECT_GT(result["cases"].get<int>(), 50);

  const Csv sweep = read_csv(dir.path / "stability_sweep.csv");
  ASSERT_EQ(static_cast<int>(sweep.rows.size()), result["cases"].get<int>());
  for (std::size_t i = 0; i < sweep.rows.size(); ++i) {
    EXPECT_NE(sweep.text(i, "agreement"), "DISAGREE") << sweep.text(i, "name");
    EXPECT_FALSE(sweep.text(i, "gate").empty()) << sweep.text(i, "name");
  }
  // Hulin Remark 2 in the wall map's data.
  const Csv wall = read_csv(dir.path / "stability_wall_region.csv");
  int maxima = 0;
  for (std::size_t i = 0; i < wall.rows.size(); ++i) {
    if (wall.text(i, "curve") != "maximum-stiffness") continue;
    if (wall.number(i, "delay") == 0) {
      EXPECT_NEAR(wall.number(i, "alpha"), 12 - 8 * std::sqrt(2.0), 1e-9);
      EXPECT_NEAR(wall.number(i, "beta"), 2 * std::sqrt(2.0) - 2, 1e-6);
    }
    if (wall.number(i, "delay") == 1) {
      EXPECT_NEAR(wall.number(i, "alpha"), 0.144469, 1e-6);
      EXPECT_NEAR(wall.number(i, "beta"), 0.424694, 1e-6);
    }
    ++maxima;
  }
  EXPECT_EQ(maxima, 9);  // d = 0 .. 8
  // Colgate & Schenkel beside it (device damping 2 N s/m: b T/m = 0.02), for
  // beta in (0, 0.02): the requirement lies between (alpha/2)(2d+1) - beta (its
  // value as w -> 0) and (alpha/2)(2d+1) + beta, so 2 (0.02 - beta)/(2d+1) <=
  // alpha <= 2 (0.02 + beta)/(2d+1); the operating point (Hulin section 7)
  // needs 50.72 N s/m.
  int passive = 0;
  for (std::size_t i = 0; i < wall.rows.size(); ++i) {
    if (wall.text(i, "curve") != "passivity-boundary") continue;
    const double d = wall.number(i, "delay"), beta = wall.number(i, "beta"), alpha = wall.number(i, "alpha");
    EXPECT_LT(beta, 0.02);
    EXPECT_GT(alpha, 0.0);
    EXPECT_LE(alpha, 2 * (0.02 + beta) / (2 * d + 1) * (1 + 1e-12)) << d << " " << beta;
    EXPECT_GE(alpha, 2 * (0.02 - beta) / (2 * d + 1) * (1 - 1e-12)) << d << " " << beta;
    ++passive;
  }
  EXPECT_GT(passive, 9 * 10);
  EXPECT_NEAR(result["passivity"]["operating_point"]["required_damping"].get<double>(), 50.5 + 81.0 / 368.0,
              1e-9);
  EXPECT_FALSE(result["passivity"]["operating_point"]["passive"].get<bool>());
  EXPECT_NEAR(result["passivity"]["maxima"][1]["alpha_at_zero_beta"].get<double>(), 0.04 / 3, 1e-12);
  // Freudenberg 2.14 in the integrator map: forward Euler needs zeta > w_n T / 2.
  const Csv integrators = read_csv(dir.path / "stability_integrator_regions.csv");
  int euler = 0;
  for (std::size_t i = 0; i < integrators.rows.size(); ++i) {
    if (integrators.text(i, "integrator") != "forward-euler" || integrators.number(i, "wn_t") > 1) continue;
    const double h = integrators.number(i, "wn_t");
    EXPECT_NEAR(integrators.number(i, "zeta_lower") / (h / 2), 1.0, 3e-12 / (h * h) + 1e-8) << h;
    ++euler;
  }
  EXPECT_GT(euler, 10);
  // The Jury closed form at td = 0 (rigid LHifAM: m = 5.4 kg, b = 3.5 N s/m, T = 1 ms).
  const double m = 5.4, b = 3.5, t = 1e-3, c = b / m, a = std::exp(-c * t);
  const double jury = (1 - a) / (((1 - a) - c * t * a) / (m * c * c));
  const Csv kcr = read_csv(dir.path / "stability_critical_stiffness.csv");
  bool found = false;
  for (std::size_t i = 0; i < kcr.rows.size(); ++i) {
    if (kcr.text(i, "plant") == "rigid" && kcr.number(i, "delay_ms") == 0.0) {
      EXPECT_NEAR(kcr.number(i, "k_cr") / jury, 1.0, 1e-6);
      found = true;
    }
  }
  EXPECT_TRUE(found);
}

// `hapticctl report passivity` (issue 21): the table, both figures and the
// numbers behind them, read back from the CSV.
TEST(ReportPassivityCli, WritesBothFiguresAndPrintsTheTable) {
  TempDir dir;
  const auto r = run(hapticctl_binary(), {"report", "passivity", "--out", dir.path.string()}, 60s);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("fixed-gain limit K_limit = 14342 N/m"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("K/limit"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("alpha peak"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 *"), std::string::npos) << "the gate's factor is marked\n" << r.out;
  EXPECT_NE(r.out.find("diverged at"), std::string::npos) << r.out;
  const bool gnuplot = std::system("command -v gnuplot >/dev/null 2>&1") == 0;
  for (const char* figure : {"passivity_transparency", "passivity_damping"}) {
    for (const char* ext : {".csv", ".json", ".gp"}) {
      EXPECT_TRUE(fs::exists(dir.path / (std::string(figure) + ext))) << figure << ext;
    }
    if (gnuplot) {
      EXPECT_TRUE(is_png(dir.path / (std::string(figure) + ".png"))) << figure;
    }
    const auto json = nlohmann::json::parse(std::ifstream(dir.path / (std::string(figure) + ".json")));
    EXPECT_NEAR(json["fixed_gain_limit"].get<double>(), 14342.0, 1.0) << figure;
    EXPECT_EQ(json["gate_factor"].get<double>(), 2.0) << figure;
  }
  const std::string script = [&] {
    std::ifstream in(dir.path / "passivity_transparency.gp");
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }();
  EXPECT_NE(script.find("set logscale y"), std::string::npos);
  EXPECT_NE(script.find("gate's factor 2 x"), std::string::npos);
  const Csv data = read_csv(dir.path / "passivity_transparency.csv");
  ASSERT_EQ(data.rows.size(), 14u);  // 7 factors, off and controller
  for (std::size_t i = 0; i < data.rows.size(); ++i) {
    const double factor = data.number(i, "factor");
    const bool controller = data.text(i, "passivity") == "controller";
    EXPECT_NEAR(data.number(i, "stiffness") / (factor * 14342.0), 1.0, 1e-4);
    EXPECT_LE(data.number(i, "peak_damping"), 30.0);
    if (controller) {
      EXPECT_EQ(data.text(i, "verdict"), "bounded") << factor;
    } else {
      EXPECT_EQ(data.number(i, "peak_damping"), 0.0) << factor;
      if (factor > 1.0) {
        EXPECT_NE(data.text(i, "verdict"), "bounded") << factor;
      }
    }
  }
  for (const auto& name : names_in(dir.path)) EXPECT_EQ(name.find(".part-"), std::string::npos) << name;
}

TEST(ReportPassivityCli, JsonHasEveryRowAndNoVerdictFromNonFiniteNumbers) {
  TempDir dir;
  const auto r =
      run(hapticctl_binary(),
          {"report", "passivity", "--factors", "0.5,2,5", "--out", dir.path.string(), "--json"}, 60s);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto study = nlohmann::json::parse(r.out);
  ASSERT_EQ(study["rows"].size(), 3u);
  for (const auto& row : study["rows"]) {
    for (const char* mode : {"off", "controller"}) {
      const auto& x = row[mode];
      if (x["verdict"] == "bounded") {
        EXPECT_TRUE(x["rms_error"].is_number()) << row;
        EXPECT_TRUE(x["late_ratio"].is_number()) << row;
      }
    }
  }
  EXPECT_EQ(study["rows"][2]["off"]["verdict"], "diverged");
  EXPECT_TRUE(study["rows"][2]["off"]["late_ratio"].is_null());
  EXPECT_EQ(study["rows"][2]["controller"]["verdict"], "bounded");
}

TEST(ReportPassivityCli, BadArgumentsAreUsageErrors) {
  TempDir dir;
  const fs::path out = dir.path / "out";
  const auto factor =
      run(hapticctl_binary(), {"report", "passivity", "--factors", "1,0", "--out", out.string()});
  EXPECT_EQ(factor.exit_code, 2);
  EXPECT_NE(factor.err.find("--factors: '0' is not accepted"), std::string::npos) << factor.err;
  const auto delay = run(hapticctl_binary(), {"report", "passivity", "--delay", "20", "--out", out.string()});
  EXPECT_EQ(delay.exit_code, 2);
  EXPECT_NE(delay.err.find("--delay: '20' is not accepted"), std::string::npos) << delay.err;
  const auto damping =
      run(hapticctl_binary(), {"report", "passivity", "--damping", "1000", "--out", out.string()});
  EXPECT_EQ(damping.exit_code, 2);
  EXPECT_NE(damping.err.find("no stiffness > 0 is stable with fixed gains at B = 1000 N s/m"),
            std::string::npos)
      << damping.err;
  EXPECT_FALSE(fs::exists(out)) << "nothing written on a usage error";
}

}  // namespace
}  // namespace hapticd::e2e::report_cli_test
