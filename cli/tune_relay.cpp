// hapticctl tune relay: Diaz & Gil section V through the running daemon. The
// relay scene (with the experiment's delay t_d and a duration after which it
// stops by itself) drives the device into its limit cycle; the recording
// gives the oscillation frequency and the ultimate gain (the empirical
// transfer function at the peak of the averaged spectra, and the describing
// function), printed as a table like Diaz & Gil's Table II beside the
// critical stiffness of the device model in force, with the relay's own bias
// on that model (simulated) and the estimate corrected by it.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <numbers>
#include <sstream>

#include <unistd.h>

#include "analysis/relay_simulation.hpp"
#include "cli/analyze_common.hpp"
#include "cli/experiment.hpp"
#include "cli/experiment_session.hpp"
#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "world/relay_scene.hpp"
#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::cli {

namespace {

using nlohmann::json;

struct TuneArgs {
  std::string amplitude;
  std::string hysteresis = "0";
  std::string delays = "0";
  std::string duration = "20s";
  std::string settle;
  std::string start_offset;
  std::string rest = "2s";
  int trials = 1;
  int restarts = 1;
  std::string out = "hapticd-tune";
  bool keep_recordings = false;
};

struct TuneSettings {
  double amplitude = 0.0;
  double hysteresis = 0.0;
  std::vector<double> delays_s;
  double duration_s = 20.0;
  double settle_s = 5.0;
  std::optional<double> start_offset;
  double rest_s = 2.0;
};

double number_flag(const std::string& flag, const std::string& text, double low, bool low_inclusive) {
  const auto v = world::units::parse_finite(text);
  if (!v || !(low_inclusive ? *v >= low : *v > low)) {
    throw UsageError(flag + ": '" + text + "' is not accepted; a finite number " +
                     (low_inclusive ? ">= " : "> ") + fmt(low) + " (SI units)");
  }
  return *v;
}

double duration_flag(const std::string& flag, const std::string& text) {
  const auto v = world::units::parse_duration_s(text);
  if (!v || !(*v > 0.0) || *v > 1e5) {
    throw UsageError(flag + ": '" + text + "' is not accepted; a duration > 0 and up to 1e5 s (s, ms, us)");
  }
  return *v;
}

std::vector<double> delay_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const auto v = world::units::parse_duration_s(item);
    if (!v || !(*v >= 0.0)) {
      throw UsageError("--delay: '" + item +
                       "' is not accepted; durations >= 0 separated by commas, e.g. 0,2ms,8ms");
    }
    out.push_back(*v);
  }
  if (out.empty()) throw UsageError("--delay: give at least one delay, e.g. 0 or 0,4ms,8ms");
  return out;
}

struct Trial {
  int trial = 1;
  double delay_s = 0.0;
  int delay_samples = 0;
  double start_offset = 0.0;
  int restarts = 0;
  analysis::RelayAnalysis measured;
  analysis::RelayBias bias;            ///< the same relay simulated on the model
  std::optional<std::size_t> settled;  ///< the model's crossover the device's relay settled on
  bool on_critical = false;
  std::vector<RecordedSample> steady;
  std::string warning;
};

std::string hz(double omega) {
  return world::text::format_significant(omega / (2.0 * std::numbers::pi), world::text::precision::summary);
}

/// Where the measured oscillation sits among the model's crossovers, in words.
std::string crossover_words(const Trial& t) {
  const auto& xs = t.bias.crossovers;
  if (!t.measured.spectrum) return "no oscillation";
  if (!t.measured.steady) return "none: not steady";
  if (!t.settled) {
    std::string nearest;
    double best = 1e300;
    for (const auto& x : xs) {
      const double d =
          std::abs(std::log(2 * std::numbers::pi * t.measured.spectrum->frequency_hz / x.omega_rad_per_s));
      if (x.omega_rad_per_s > 0.0 && d < best) {
        best = d;
        nearest = hz(x.omega_rad_per_s) + " Hz";
      }
    }
    return "none (nearest " + (nearest.empty() ? std::string("-") : nearest) + ")";
  }
  return hz(xs[*t.settled].omega_rad_per_s) + " Hz" + (t.on_critical ? " (K_CR)" : "");
}

class RelayTuning {
 public:
  RelayTuning(ExperimentSession& session, TuneSettings settings, const TuneArgs& args)
      : session_(session), s_(std::move(settings)), args_(args) {}

  std::vector<Trial> run() {
    for (const double delay : s_.delays_s) samples_of(delay);  // every delay checked before anything moves
    std::vector<Trial> trials;
    for (const double delay : s_.delays_s) {
      for (int k = 1; k <= args_.trials; ++k) trials.push_back(run_trial(delay, k));
    }
    return trials;
  }

 private:
  int samples_of(double delay_s) const {
    const double periods = delay_s / session_.period_s();
    const double whole = std::round(periods);
    if (std::abs(periods - whole) > 1e-6 * std::max(1.0, whole)) {
      throw UsageError("--delay: " + world::units::format_duration(delay_s) +
                       " is not a whole number of loop periods (" +
                       world::units::format_duration(session_.period_s()) + ")");
    }
    if (whole > static_cast<double>(world::max_relay_delay_samples)) {
      throw UsageError("--delay: " + world::units::format_duration(delay_s) + " is more than the relay's " +
                       std::to_string(world::max_relay_delay_samples) + " periods");
    }
    return static_cast<int>(whole);
  }

  analysis::SampledRelay relay_on_model(int delay_samples, double offset) const {
    const DaemonModel& m = session_.model();
    analysis::SampledRelay r;
    r.plant = m.plant;
    r.sensor = m.sensor;
    r.period_s = m.period_s;
    r.device_delay = m.delay_periods;
    r.resolution = m.resolution;
    r.torque_limit = session_.torque_limit();
    r.amplitude = s_.amplitude;
    r.hysteresis = s_.hysteresis;
    r.delay_samples = delay_samples;
    r.start_offset = offset;
    return r;
  }

  /// The start: the amplitude of the model's slow limit cycle, 4 h / (pi K_CR).
  double default_offset(int delay_samples) const {
    const DaemonModel& m = session_.model();
    const auto k = analysis::critical_stiffness(m.plant, m.sensor, m.period_s,
                                                (m.delay_periods + delay_samples) * m.period_s);
    if (k.assessed() && k.k_cr > 0.0) return 4.0 * s_.amplitude / (std::numbers::pi * k.k_cr);
    return std::max(100.0 * m.resolution, 1e-4);
  }

  std::vector<RecordedSample> record_relay(int delay_samples, double offset, std::int64_t steps) {
    const std::string name = "hapticctl-tune-relay-" + std::to_string(::getpid()) + ".csv";
    const auto file = session_.start_recording(name);
    const double y0 = session_.position();
    const std::uint64_t c0 =
        session_.load("relay", {{"amplitude", s_.amplitude},
                                {"hysteresis", s_.hysteresis},
                                {"reference", y0 - offset},
                                {"delay", delay_samples},
                                {"duration", static_cast<double>(steps) * session_.period_s()}});
    session_.wait_for_cycle(c0 + static_cast<std::uint64_t>(steps));
    session_.stop_recording();
    const auto settle = static_cast<std::uint64_t>(std::llround(s_.settle_s / session_.period_s()));
    auto rows = read_recorded(file, c0 + settle, c0 + static_cast<std::uint64_t>(steps));
    if (!args_.keep_recordings) {
      std::error_code ignored;
      std::filesystem::remove(file, ignored);
    }
    return rows;
  }

  Trial run_trial(double delay_s, int k) {
    Trial t;
    t.trial = k;
    t.delay_s = delay_s;
    t.delay_samples = samples_of(delay_s);
    t.start_offset = s_.start_offset.value_or(default_offset(t.delay_samples));
    const auto steps = static_cast<std::int64_t>(std::llround(s_.duration_s / session_.period_s()));
    const auto settle = static_cast<std::int64_t>(std::llround(s_.settle_s / session_.period_s()));
    for (int attempt = 0;; ++attempt) {
      t.restarts = attempt;
      t.steady = record_relay(t.delay_samples, t.start_offset, steps);
      std::vector<double> y, f;
      for (const auto& r : t.steady) {
        y.push_back(r.position);
        f.push_back(r.force);
      }
      t.measured = analysis::analyze_relay(y, f, session_.period_s(), s_.amplitude);
      t.bias = analysis::relay_bias(relay_on_model(t.delay_samples, t.start_offset), steps, settle);
      const auto critical = analysis::critical_crossover(t.bias.crossovers);
      t.settled = t.measured.spectrum
                      ? analysis::matching_crossover(t.bias.crossovers, t.measured.spectrum->frequency_hz)
                      : std::nullopt;
      t.on_critical = t.measured.steady && t.settled && t.settled == critical;
      // Zero output a while before the next run (the relay stopped by itself).
      const std::uint64_t now = session_.status().at("cycle").get<std::uint64_t>();
      session_.wait_for_cycle(now +
                              static_cast<std::uint64_t>(std::llround(s_.rest_s / session_.period_s())));
      if (t.on_critical || attempt >= args_.restarts) break;
      std::cerr << "hapticctl: trial " << k << " at " << fmt(delay_s * 1e3) << " ms: the relay oscillated at "
                << (t.measured.spectrum ? fmt(t.measured.spectrum->frequency_hz) + " Hz"
                                        : std::string("nothing"))
                << ", crossover " << crossover_words(t) << ", not on the one that sets K_CR"
                << (critical ? " (" + hz(t.bias.crossovers[*critical].omega_rad_per_s) + " Hz)"
                             : std::string())
                << "; restarting from a start offset 10 times larger\n";
      t.start_offset *= 10.0;
    }
    if (!t.measured.spectrum) {
      t.warning = "no oscillation in the record: is the device free to move, and h large enough?";
    } else if (!t.measured.steady) {
      t.warning =
          "the oscillation changed during the run (" + fmt(t.measured.first_half_hz) +
          " Hz in the first half, " + fmt(t.measured.second_half_hz) +
          " Hz in the second): no steady limit cycle, its gain is not the critical stiffness; a longer "
          "--duration or --settle, or a hysteresis band, may help";
    } else if (!t.on_critical) {
      std::ostringstream w;
      const double loop_phase = t.measured.spectrum->phase_deg - 360.0 * t.measured.spectrum->frequency_hz *
                                                                     (t.delay_samples * session_.period_s());
      w << "the relay settled at " << fmt(t.measured.spectrum->frequency_hz) << " Hz, on crossover "
        << crossover_words(t) << " of the model, not on the one that sets K_CR: its gain ("
        << fmt(t.measured.spectrum->gain_margin_db) << " dB) is not the critical stiffness";
      if (!t.settled) {
        w << "; the loop phase there is " << fmt(std::remainder(loop_phase, 360.0))
          << " deg: the relay switches off the crossover (a cable mode ringing after each switch?); "
             "a hysteresis band wider than the ringing (--hysteresis) may help";
      }
      t.warning = w.str();
    }
    return t;
  }

  ExperimentSession& session_;
  TuneSettings s_;
  const TuneArgs& args_;
};

// ---- output ---------------------------------------------------------------

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  const std::string out = world::text::format_fixed(v, decimals);
  return out == "-0.00" ? "0.00" : out;
}
std::string db(double v) { return fixed(v, 2); }
std::string sig4(double v) {
  if (!std::isfinite(v)) return "-";
  return world::text::format_significant(v, world::text::precision::summary);
}

json trial_json(const Trial& t) {
  json j{{"trial", t.trial},
         {"delay_s", t.delay_s},
         {"delay_samples", t.delay_samples},
         {"start_offset", t.start_offset},
         {"restarts", t.restarts},
         {"on_critical_crossover", t.on_critical},
         {"warning", t.warning.empty() ? json(nullptr) : json(t.warning)}};
  if (const auto& s = t.measured.spectrum) {
    j["frequency_hz"] = s->frequency_hz;
    j["gain_margin_db"] = s->gain_margin_db;
    j["k_cr"] = s->ultimate_gain;
    j["phase_deg"] = s->phase_deg;
    if (t.bias.usable() && t.on_critical) {
      j["corrected"] = {{"gain_margin_db", s->gain_margin_db - t.bias.spectrum_gain_db},
                        {"k_cr", s->ultimate_gain * std::pow(10.0, -t.bias.spectrum_gain_db / 20.0)},
                        {"frequency_hz", s->frequency_hz / t.bias.spectrum_frequency_ratio}};
    }
  }
  if (const auto& d = t.measured.describing_function) {
    j["describing_function"] = {{"k_cr", d->ultimate_gain},
                                {"gain_margin_db", d->gain_margin_db},
                                {"frequency_hz", d->frequency_hz},
                                {"amplitude", d->amplitude}};
  }
  j["model"] = {{"k_cr", t.bias.model.k_cr},
                {"gain_margin_db", t.bias.model.gain_margin_db},
                {"frequency_hz", t.bias.model.crossover_hz},
                {"assessed", t.bias.model.assessed()}};
  j["bias"] = {{"gain_db", t.bias.usable() ? json(t.bias.spectrum_gain_db) : json(nullptr)},
               {"frequency_ratio", t.bias.usable() ? json(t.bias.spectrum_frequency_ratio) : json(nullptr)},
               {"describing_gain_db", t.bias.usable() ? json(t.bias.describing_gain_db) : json(nullptr)}};
  json xs = json::array();
  for (const auto& x : t.bias.crossovers) {
    xs.push_back({{"frequency_hz", x.omega_rad_per_s / (2 * std::numbers::pi)}, {"stiffness", x.stiffness}});
  }
  j["crossovers"] = xs;
  j["settled_on"] = t.settled ? json(*t.settled) : json(nullptr);
  j["steady"] = t.measured.steady;
  j["first_half_hz"] = t.measured.first_half_hz;
  j["second_half_hz"] = t.measured.second_half_hz;
  return j;
}

void print_table(const std::vector<Trial>& trials, const MotionUnits& u) {
  TextTable table({"trial", "delay ms", "f Hz", "Gm dB", "K_CR " + u.stiffness, "corr. Hz", "corr. dB",
                   "corr. K_CR", "model Hz", "model dB", "model K_CR", "raw-model dB", "corr-model dB",
                   "crossover"});
  for (const Trial& t : trials) {
    const auto& s = t.measured.spectrum;
    const bool corrected = s && t.bias.usable() && t.on_critical;
    const double corr_db = corrected ? s->gain_margin_db - t.bias.spectrum_gain_db : std::nan("");
    const double model_db = t.bias.model.assessed() ? t.bias.model.gain_margin_db : std::nan("");
    table.row({std::to_string(t.trial) + (t.warning.empty() ? "" : "!"), fmt(t.delay_s * 1e3),
               s ? sig4(s->frequency_hz) : "-", s ? db(s->gain_margin_db) : "-",
               s ? sig4(s->ultimate_gain) : "-",
               corrected ? sig4(s->frequency_hz / t.bias.spectrum_frequency_ratio) : "-", db(corr_db),
               corrected ? sig4(std::pow(10.0, corr_db / 20.0)) : "-",
               t.bias.model.assessed() ? sig4(t.bias.model.crossover_hz) : "-", db(model_db),
               t.bias.model.assessed() ? sig4(t.bias.model.k_cr) : "-",
               s ? db(s->gain_margin_db - model_db) : "-", db(corr_db - model_db), crossover_words(t)});
  }
  table.print(std::cout);
}

void print_bias(const std::vector<Trial>& trials) {
  std::cout << "relay bias on the model (the same relay simulated; corrected = measured less it):\n";
  double last_delay = -1.0;
  for (const Trial& t : trials) {
    if (t.delay_s == last_delay) continue;
    last_delay = t.delay_s;
    std::cout << "  delay " << fmt(t.delay_s * 1e3) << " ms: ";
    if (t.bias.usable()) {
      std::cout << db(t.bias.spectrum_gain_db) << " dB, "
                << fixed(100 * (t.bias.spectrum_frequency_ratio - 1), 1)
                << " % in frequency (describing function " << db(t.bias.describing_gain_db) << " dB)\n";
    } else {
      std::cout << "none: on the model this relay does not settle steadily on the crossover that sets K_CR\n";
    }
  }
}

Figure limit_cycle_figure(const Trial& t, const MotionUnits& u, double period_s) {
  const bool linear = u.position == "m";
  const double scale = 1e3;  // mm or mrad
  Figure f;
  f.command = "hapticctl tune relay";
  f.name = "relay_limit_cycle_" + fmt(t.delay_s * 1e3) + "ms";
  f.title =
      "Relay limit cycle at t_d = " + fmt(t.delay_s * 1e3) + " ms (trial " + std::to_string(t.trial) + ")";
  f.x = {"time (s)", false, ""};
  f.y = {std::string("position (") + (linear ? "mm" : "mrad") + ")", false, ""};
  f.data.columns = {"time_s", "position", "force"};
  const double cycles_s = t.measured.spectrum ? 4.0 / t.measured.spectrum->frequency_hz : 1.0;
  const auto count =
      std::min<std::size_t>(t.steady.size(), static_cast<std::size_t>(cycles_s / period_s) + 1);
  const std::size_t from = t.steady.size() - count;
  for (std::size_t i = from; i < t.steady.size(); ++i) {
    f.data.rows.push_back(
        {static_cast<double>(i - from) * period_s, t.steady[i].position * scale, t.steady[i].force});
  }
  f.decorations = {"set y2tics", "set ytics nomirror", "set y2label 'force (" + u.force + ")'"};
  f.curves = {{"position", {}, "time_s", "position", "lines lw 2 lc rgb '#2166ac'"},
              {"force (right axis)", {}, "time_s", "force", "steps lw 1 lc rgb '#d95f02' axes x1y2"}};
  f.key = "outside below center horizontal";
  return f;
}

/// Diaz & Gil Fig. 12 against the delay: the model's gain margin, the
/// measured and the corrected points.
Figure gain_margin_figure(const std::vector<Trial>& trials, const DaemonModel& m) {
  Figure f;
  f.command = "hapticctl tune relay";
  f.name = "relay_gain_margin";
  f.title = "Critical stiffness against the delay: relay (Diaz & Gil V) and model\n" + m.summary;
  f.x = {"delay t_d (ms)", false, ""};
  f.y = {"gain margin 20 log10 K_{CR} (dB)", false, ""};
  f.data.columns = {"series", "delay_ms", "gm_db"};
  double max_delay = 0.0;
  for (const Trial& t : trials) max_delay = std::max(max_delay, t.delay_s);
  const double span_ms = std::max(max_delay, 1e-3) * 1e3;
  f.x.range = "[" + fmt(-0.05 * span_ms) + ":" + fmt(1.05 * span_ms) + "]";
  const int points = 60;
  for (int i = 0; i <= points; ++i) {
    const double td = max_delay * i / points;
    const auto k =
        analysis::critical_stiffness(m.plant, m.sensor, m.period_s, m.delay_periods * m.period_s + td);
    if (k.assessed()) f.data.rows.push_back({std::string("model"), td * 1e3, k.gain_margin_db});
  }
  for (const Trial& t : trials) {
    if (!t.measured.spectrum) continue;
    f.data.rows.push_back({std::string("measured"), t.delay_s * 1e3, t.measured.spectrum->gain_margin_db});
    if (t.bias.usable() && t.on_critical) {
      f.data.rows.push_back({std::string("corrected"), t.delay_s * 1e3,
                             t.measured.spectrum->gain_margin_db - t.bias.spectrum_gain_db});
    }
  }
  f.curves = {{"model (critical stiffness)",
               {{"series", std::string("model")}},
               "delay_ms",
               "gm_db",
               "lines lw 2 lc rgb '#555555'"},
              {"relay, measured",
               {{"series", std::string("measured")}},
               "delay_ms",
               "gm_db",
               "points pt 6 ps 1.6 lc rgb '#d95f02'"},
              {"relay, corrected for its bias",
               {{"series", std::string("corrected")}},
               "delay_ms",
               "gm_db",
               "points pt 7 ps 1.0 lc rgb '#2166ac'"}};
  return f;
}

/// The flags that need no daemon, checked before it is reached (the
/// amplitude's default and limit come from the daemon).
TuneSettings tune_settings_from_flags(const TuneArgs& args) {
  TuneSettings s;
  s.hysteresis = number_flag("--hysteresis", args.hysteresis, 0.0, true);
  s.delays_s = delay_list(args.delays);
  s.duration_s = duration_flag("--duration", args.duration);
  s.rest_s = duration_flag("--rest", args.rest);
  if (!args.start_offset.empty())
    s.start_offset = number_flag("--start-offset", args.start_offset, 0.0, false);
  s.settle_s =
      args.settle.empty() ? std::max(2.0, 0.25 * s.duration_s) : duration_flag("--settle", args.settle);
  if (!(s.settle_s < s.duration_s)) {
    throw UsageError("--settle " + world::units::format_duration(s.settle_s) +
                     " must be shorter than --duration " + world::units::format_duration(s.duration_s));
  }
  return s;
}

/// --amplitude: half the daemon's torque limit by default, never above it.
double relay_amplitude_flag(const TuneArgs& args, const ExperimentSession& session, const MotionUnits& u) {
  const double amplitude = args.amplitude.empty() ? 0.5 * session.torque_limit()
                                                  : number_flag("--amplitude", args.amplitude, 0.0, false);
  if (amplitude > session.torque_limit()) {
    throw UsageError("--amplitude " + fmt(amplitude) + " " + u.force +
                     " is above the daemon's torque limit " + fmt(session.torque_limit()) + " " + u.force +
                     ": the limit would clip the relay");
  }
  return amplitude;
}

/// One limit-cycle figure for each delay that reached a steady state, then the gain margin against the delay.
void write_relay_figures(FigureWriter& writer, const std::vector<Trial>& trials, const MotionUnits& u,
                         const ExperimentSession& session) {
  double last_delay = -1.0;
  for (const Trial& t : trials) {
    if (t.delay_s == last_delay || t.steady.empty()) continue;
    last_delay = t.delay_s;
    writer.write(limit_cycle_figure(t, u, session.period_s()));
  }
  writer.write(gain_margin_figure(trials, session.model()));
}

/// relay_trials.json (and --json's output).
json relay_trials_json(const ExperimentSession& session, const TuneSettings& s, const MotionUnits& u,
                       const std::vector<Trial>& trials, const std::string& restored) {
  json all{{"device", session.model().summary},
           {"model_source", session.model().source},
           {"relay",
            {{"amplitude", s.amplitude},
             {"hysteresis", s.hysteresis},
             {"duration_s", s.duration_s},
             {"settle_s", s.settle_s}}},
           {"units", {{"stiffness", u.stiffness}, {"force", u.force}, {"position", u.position}}},
           {"trials", json::array()},
           {"restored", restored}};
  for (const Trial& t : trials) all["trials"].push_back(trial_json(t));
  return all;
}

/// The table's heading: the device, the relay and how each trial is read.
void print_relay_summary(const ExperimentSession& session, const TuneSettings& s, const MotionUnits& u) {
  std::cout
      << "relay experiment (Diaz & Gil V) on " << session.driver() << ": " << session.model().summary
      << " (model: " << session.model().source << ")\n"
      << "relay h = " << fmt(s.amplitude) << " " << u.force << ", hysteresis " << fmt(s.hysteresis) << " "
      << u.position << ", " << fmt(s.duration_s) << " s per trial, the first " << fmt(s.settle_s)
      << " s dropped; frequency and gain from the empirical transfer function at the peak of the averaged "
         "spectra\n";
}

void warn_about_trials(const std::vector<Trial>& trials) {
  for (const Trial& t : trials) {
    if (!t.warning.empty()) {
      std::cerr << "hapticctl: warning: trial " << t.trial << " at " << fmt(t.delay_s * 1e3)
                << " ms: " << t.warning << "\n";
    }
  }
}

int run_tune(const hapticctl::CommonOptions& opts, const TuneArgs& args) {
  TuneSettings s = tune_settings_from_flags(args);
  StagedFiles files = open_output(args.out);
  ExperimentSession session(opts);
  const MotionUnits u = units_of(session.model().motion);
  s.amplitude = relay_amplitude_flag(args, session, u);
  std::vector<Trial> trials;
  try {
    RelayTuning tuning(session, s, args);
    trials = tuning.run();
  } catch (const Interrupted&) {
    std::cerr << "hapticctl: tune relay stopped by Ctrl-C; " << session.restore()
              << "; the device is at zero output until then; nothing written\n";
    return exit_experiment_interrupted;
  }
  const std::string restored = session.restore();

  FigureWriter writer(files);
  write_relay_figures(writer, trials, u, session);
  const json all = relay_trials_json(session, s, u, trials, restored);
  files.stage("relay_trials.json", all.dump(1) + "\n");
  const auto written = files.commit();
  bool warned = false;
  for (const Trial& t : trials) warned = warned || !t.warning.empty();
  if (opts.json) {
    hapticctl::detail::print_json(all);
    return warned ? exit_refused : exit_ok;
  }
  print_relay_summary(session, s, u);
  print_table(trials, u);
  print_bias(trials);
  warn_about_trials(trials);
  writer.report_problems(files.dir());
  std::cout << restored << "\n" << written.size() << " files in " << files.dir().string() << "\n";
  return warned ? exit_refused : exit_ok;
}

}  // namespace

void add_tune_command(CLI::App& app, hapticctl::CommonOptions& opts) {
  auto* tune =
      app.add_subcommand("tune", "Experiments that tune the stability gate to the device (needs hapticd)");
  tune->require_subcommand(1);
  hapticctl::add_common_options(*tune, opts);
  auto args = std::make_shared<TuneArgs>();
  auto* relay = tune->add_subcommand(
      "relay", "Diaz & Gil V: the critical stiffness by a relay on the running device, beside the model's");
  hapticctl::add_common_options(*relay, opts);
  relay->add_option("--amplitude", args->amplitude, "relay h, N (N m); default: half the torque limit");
  relay->add_option("--hysteresis", args->hysteresis, "relay hysteresis eps, m (rad); default 0");
  relay->add_option(
      "--delay", args->delays,
      "extra loop delay t_d, a whole number of periods; a list for a table, e.g. 0,2ms,4ms,8ms");
  relay->add_option("--duration", args->duration, "per trial (s, ms, us; default 20s)");
  relay->add_option("--settle", args->settle,
                    "transient dropped from each trial (default a quarter, >= 2 s)");
  relay->add_option("--trials", args->trials, "trials per delay (default 1)")->check(CLI::Range(1, 100));
  relay->add_option(
      "--start-offset", args->start_offset,
      "initial error of the relay, m (rad); default: the model's predicted amplitude 4h/(pi K_CR)");
  relay
      ->add_option("--restarts", args->restarts,
                   "restarts from a 10x larger start when the relay settles off K_CR's crossover (default 1)")
      ->check(CLI::Range(0, 5));
  relay->add_option("--rest", args->rest, "zero output between trials (default 2s)");
  relay->add_option("--out", args->out,
                    "directory for the figures and relay_trials.json (default hapticd-tune)");
  relay->add_flag("--keep-recordings", args->keep_recordings, "keep the daemon's recording of each trial");
  relay->callback([&opts, args] {
    const int code = run_tune(opts, *args);
    if (code != exit_ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli
