// hapticctl identify: the device model from a chirp through the running
// daemon (Diaz & Gil II, Fig. 4 and eq. 2, 5-9). The chirp scene (a
// periodic exponential sweep of bounded force that stops by itself) excites
// the device held as --hand says (the loopback's simulated hand is scripted
// so; on a real device the user holds it so); the recording gives the
// frequency response, and a least-squares fit the rigid or the two-mass model
// with 95 % intervals. The model can be written as a file the config names
// and, with --apply, made the one the stability gate uses.

#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <sstream>

#include <unistd.h>

#include "analysis/identification.hpp"
#include "cli/analyze_common.hpp"
#include "cli/experiment.hpp"
#include "cli/experiment_session.hpp"
#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "world/units.hpp"

namespace hapticd::cli {

namespace {

using analysis::HandCondition;
using analysis::IdentifiedPlant;
using nlohmann::json;

struct IdentifyArgs {
  std::string plant;
  std::string hand = "free";
  std::string hand_stiffness;
  std::string hand_damping = "0";
  std::string amplitude;
  std::string start_frequency = "0.5";
  std::string end_frequency;
  std::string sweep = "20s";
  int sweeps = 3;
  std::string out = "hapticd-identify";
  std::string model_file;
  bool apply = false;
  bool keep_recordings = false;
};

double positive(const std::string& flag, const std::string& text, bool zero_ok = false) {
  const auto v = world::units::parse_finite(text);
  if (!v || !(zero_ok ? *v >= 0.0 : *v > 0.0)) {
    throw UsageError(flag + ": '" + text + "' is not accepted; a finite number " +
                     (zero_ok ? ">= 0" : "> 0") + " (SI units)");
  }
  return *v;
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  std::ostringstream out;
  out << std::put_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  return out.str();
}

std::string exact(double v) {
  std::ostringstream out;
  out << std::setprecision(8) << v;
  return out.str();
}

std::string sig(double v, int digits) {
  std::ostringstream out;
  out << std::setprecision(digits) << v;
  return out.str();
}

/// The delay the gate uses, in whole periods: the nearest when the fit lands
/// within 0.1 of it, else the next one up (more delay is the safe side).
int whole_delay(double periods) {
  const double nearest = std::round(periods);
  const double whole = std::abs(periods - nearest) <= 0.1 ? nearest : std::ceil(periods);
  return static_cast<int>(std::max(0.0, whole));
}

/// What the loopback was configured with, under the fitted parameters' names.
json configured_values(const ExperimentSession& session, IdentifiedPlant kind, HandCondition hand,
                       double hand_damping, std::optional<double> hand_stiffness) {
  const json& v = session.driver_values();
  if (session.driver() != "loopback" || !v.contains("plant")) return json::object();
  if (v["plant"].get<std::string>() != analysis::to_string(kind)) return json::object();
  json out = json::object();
  const auto take = [&](const char* name) {
    if (v.contains(name) && v[name].is_number()) out[name] = v[name];
  };
  for (const char* name : {"mass", "damping", "coulomb", "delay", "motor_mass", "body_mass", "motor_damping",
                           "body_damping", "cable_stiffness", "cable_damping"}) {
    take(name);
  }
  if (hand == HandCondition::spring) {
    if (out.contains("damping")) out["damping"] = out["damping"].get<double>() + hand_damping;
    if (out.contains("body_damping")) out["body_damping"] = out["body_damping"].get<double>() + hand_damping;
    if (hand_stiffness) out["hand_stiffness"] = *hand_stiffness;
  }
  if (hand == HandCondition::hold && out.contains("motor_damping")) {
    out["motor_and_cable_damping"] = out["motor_damping"].get<double>() + out["cable_damping"].get<double>();
  }
  return out;
}

/// The [model] keys of the identified device (docs/config.md, "Device model files").
nlohmann::ordered_json model_keys(const analysis::Identification& id, const ExperimentSession& session) {
  const DaemonModel& m = session.model();
  nlohmann::ordered_json keys{{"plant", std::string(analysis::to_string(id.plant_kind))},
                              {"motion", m.motion == world::Motion::rotary ? "rotary" : "linear"},
                              {"period", m.period_s},
                              {"delay", whole_delay(id.delay_periods)},
                              {"coulomb", std::max(0.0, id.coulomb)}};
  const auto put = [&](const char* name) { keys[name] = std::max(0.0, id.value(name)); };
  if (id.plant_kind == IdentifiedPlant::rigid) {
    put("mass");
    put("damping");
  } else {
    for (const char* name :
         {"motor_mass", "body_mass", "motor_damping", "body_damping", "cable_stiffness", "cable_damping"}) {
      put(name);
    }
    keys["sensor"] = std::string(world::to_string(m.sensor));
  }
  return keys;
}

std::string model_file_text(const analysis::Identification& id, const nlohmann::ordered_json& keys,
                            const std::string& how) {
  std::ostringstream out;
  out << "# hapticd device model, written by `hapticctl identify` on " << utc_now() << "\n"
      << "# " << how << "\n"
      << "# The stability gate uses it when the daemon's config names it: [device] model = \"<this file>\"\n"
      << "# (docs/config.md, \"Device model files\"). The comments give the 95 % intervals of the fit.\n"
      << "[model]\n";
  for (const auto& [key, value] : keys.items()) {
    out << key << " = "
        << (value.is_string() ? "\"" + value.get<std::string>() + "\"" : exact(value.get<double>()));
    if (key == "delay") {
      out << "  # fitted " << sig(id.delay_periods, 4) << " +- " << sig(id.find("delay")->half_width, 2)
          << " periods";
    } else if (const auto* p = id.find(key)) {
      out << "  # +- " << sig(p->half_width, 2) << " " << p->unit;
    }
    out << "\n";
  }
  return out.str();
}

/// Phase in degrees, unwrapped along the bins.
std::vector<double> unwrapped_phase(const std::vector<std::complex<double>>& values) {
  std::vector<double> out;
  double offset = 0.0, last = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    double p = std::arg(values[i]) * 180.0 / std::numbers::pi;
    if (i > 0) {
      while (p + offset - last > 180.0) offset -= 360.0;
      while (p + offset - last < -180.0) offset += 360.0;
    }
    last = p + offset;
    out.push_back(last);
  }
  return out;
}

std::vector<Figure> response_figures(const analysis::FrequencyResponse& data,
                                     const analysis::Identification& id, const MotionUnits& u,
                                     const std::string& subtitle) {
  std::vector<std::complex<double>> measured;
  for (std::size_t k = 0; k < data.size(); ++k) measured.push_back(data.response(k));
  const auto fitted_phase = unwrapped_phase(id.fitted);
  Figure magnitude;
  magnitude.command = "hapticctl identify";
  magnitude.name = "identify_magnitude";
  magnitude.title = "Frequency response: measured against fitted (" + subtitle + ")";
  magnitude.x = {"frequency (Hz)", true, ""};
  magnitude.y = {"|position / force| (dB re 1 " + u.position + "/" + u.force + ")", false, ""};
  magnitude.data.columns = {"frequency_hz", "measured_db", "fitted_db", "measured_phase_deg",
                            "fitted_phase_deg"};
  for (std::size_t k = 0; k < data.size(); ++k) {
    // The measured phase on the fitted curve's branch.
    const double wrapped = std::arg(measured[k] / id.fitted[k]) * 180.0 / std::numbers::pi;
    magnitude.data.rows.push_back({data.frequency_hz[k], 20.0 * std::log10(std::abs(measured[k])),
                                   20.0 * std::log10(std::abs(id.fitted[k])), fitted_phase[k] + wrapped,
                                   fitted_phase[k]});
  }
  magnitude.curves = {{"measured", {}, "frequency_hz", "measured_db", "points pt 7 ps 0.3 lc rgb '#d95f02'"},
                      {"fitted " + std::string(analysis::to_string(id.plant_kind)) + " model",
                       {},
                       "frequency_hz",
                       "fitted_db",
                       "lines lw 2 lc rgb '#2166ac'"}};
  Figure phase = magnitude;
  phase.name = "identify_phase";
  phase.y = {"phase (deg)", false, ""};
  phase.curves = {
      {"measured", {}, "frequency_hz", "measured_phase_deg", "points pt 7 ps 0.3 lc rgb '#d95f02'"},
      {"fitted", {}, "frequency_hz", "fitted_phase_deg", "lines lw 2 lc rgb '#2166ac'"}};
  return {magnitude, phase};
}

void print_identification(const analysis::Identification& id, const json& configured, const json& result) {
  TextTable table({"parameter", "value", "+- (95 %)", "unit", "configured", "error %", "note"});
  for (const auto& p : id.parameters) {
    std::string ref = "-", error = "-";
    if (configured.contains(p.name)) {
      const double c = configured[p.name].get<double>();
      ref = sig(c, 6);
      error = c != 0.0 ? sig(100.0 * (p.value / c - 1.0), 3) : "(" + sig(p.value - c, 2) + ")";
    }
    table.row({p.name, sig(p.value, 6), sig(p.half_width, 2), p.unit, ref, error, p.note});
  }
  table.print(std::cout);
  for (const auto& c : id.confounded) {
    std::cout << "the data cannot tell " << c.first << " from " << c.second << " (correlation "
              << fmt(c.correlation) << ")";
    if (!c.sum_name.empty()) {
      std::cout << ": only " << c.sum_name << " = " << fmt(c.sum) << " +- " << fmt(c.sum_half_width)
                << " is determined";
      if (configured.contains(c.first) && configured.contains(c.second)) {
        const double sum = configured[c.first].get<double>() + configured[c.second].get<double>();
        std::cout << " (configured " << fmt(sum) << ", error " << fmt(100.0 * (c.sum / sum - 1.0)) << " %)";
      }
    }
    std::cout << "\n";
  }
  for (const auto& note : id.notes) std::cout << "note: " << note << "\n";
  std::cout << "fit: rms error " << sig(100.0 * id.fit_error, 3) << " % of the response over "
            << result.at("bins").get<std::size_t>() << " frequencies, " << id.fit.iterations
            << " iterations (" << id.fit.stop_reason << ")\n";
}

int run_identify(const hapticctl::CommonOptions& opts, const IdentifyArgs& args) {
  const auto hand = analysis::parse_hand_condition(args.hand);
  if (!hand) throw UsageError("--hand: '" + args.hand + "' is not accepted; free, hold or spring");
  const double f0 = positive("--start-frequency", args.start_frequency);
  const auto sweep_s = world::units::parse_duration_s(args.sweep);
  if (!sweep_s || !(*sweep_s > 0.0)) throw UsageError("--sweep: '" + args.sweep + "' is not a duration > 0");
  if (args.apply && *hand != HandCondition::free) {
    throw UsageError(
        "--apply needs --hand free: held or on a spring, the run does not give the device's model");
  }
  const double hand_damping = positive("--hand-damping", args.hand_damping, true);
  StagedFiles files = open_output(args.out);
  ExperimentSession session(opts);
  const DaemonModel& model = session.model();
  const MotionUnits u = units_of(model.motion);
  IdentifiedPlant kind = model.two_mass ? IdentifiedPlant::two_mass : IdentifiedPlant::rigid;
  if (!args.plant.empty()) {
    const auto parsed = analysis::parse_identified_plant(args.plant);
    if (!parsed) throw UsageError("--plant: '" + args.plant + "' is not accepted; rigid or two-mass");
    kind = *parsed;
  }
  const double nyquist = 0.5 / model.period_s;
  const double f1 = args.end_frequency.empty()
                        ? std::min(kind == IdentifiedPlant::rigid ? 50.0 : 200.0, 0.4 / model.period_s)
                        : positive("--end-frequency", args.end_frequency);
  if (!(f1 > f0 && f1 <= nyquist)) {
    throw UsageError("--end-frequency " + fmt(f1) +
                     " Hz must lie above --start-frequency and at most at 1/(2T) = " + fmt(nyquist) + " Hz");
  }
  const double amplitude =
      args.amplitude.empty() ? 0.5 * session.torque_limit() : positive("--amplitude", args.amplitude);
  if (amplitude > session.torque_limit()) {
    throw UsageError("--amplitude " + fmt(amplitude) + " " + u.force +
                     " is above the daemon's torque limit " + fmt(session.torque_limit()) + " " + u.force);
  }
  std::optional<double> hand_stiffness;
  if (*hand == HandCondition::spring) {
    hand_stiffness =
        args.hand_stiffness.empty()
            ? model.effective_mass * std::pow(2.0 * std::numbers::pi * 1.0, 2)  // 1 Hz on the mass
            : positive("--hand-stiffness", args.hand_stiffness);
  }

  // The run.
  const auto sweep_steps = static_cast<std::int64_t>(std::llround(*sweep_s / model.period_s));
  const double duration =
      static_cast<double>(args.sweeps) * static_cast<double>(sweep_steps) * model.period_s + 1.0 / f0;
  std::vector<RecordedSample> rows;
  std::string hand_text;
  try {
    const double y0 = session.position();
    json script{{"mode", "free"}};
    if (*hand == HandCondition::hold) script = {{"mode", "hold"}, {"position", y0}};
    if (*hand == HandCondition::spring) {
      script = {
          {"mode", "impedance"}, {"stiffness", *hand_stiffness}, {"damping", hand_damping}, {"position", y0}};
    }
    const auto set = session.set_hand(script);
    hand_text = set ? "simulated hand: " + *set : "hand: " + args.hand + " (as you hold the device)";
    const std::string name = "hapticctl-identify-" + std::to_string(::getpid()) + ".csv";
    const auto file = session.start_recording(name);
    const std::uint64_t c0 =
        session.load("chirp", {{"amplitude", amplitude},
                               {"start_frequency", f0},
                               {"end_frequency", f1},
                               {"sweep", static_cast<double>(sweep_steps) * model.period_s},
                               {"duration", duration}});
    const auto end = c0 + static_cast<std::uint64_t>(args.sweeps * sweep_steps);
    std::cerr << "hapticctl: identify: " << args.sweeps << " sweeps of " << fmt(*sweep_s) << " s, "
              << fmt(amplitude) << " " << u.force << " from " << fmt(f0) << " to " << fmt(f1) << " Hz; "
              << hand_text << "\n";
    session.wait_for_cycle(c0 + static_cast<std::uint64_t>(std::llround(duration / model.period_s)));
    session.stop_recording();
    rows = read_recorded(file, c0, end);
    if (!args.keep_recordings) {
      std::error_code ignored;
      std::filesystem::remove(file, ignored);
    }
  } catch (const Interrupted&) {
    std::cerr << "hapticctl: identify stopped by Ctrl-C; " << session.restore() << "; nothing written\n";
    return exit_experiment_interrupted;
  }
  const std::string restored = session.restore();

  std::vector<double> y, f;
  for (const auto& r : rows) {
    y.push_back(r.position);
    f.push_back(r.force);
  }
  const auto data =
      analysis::measure_frequency_response(y, f, model.period_s, sweep_steps, f0 * 1.05, f1 / 1.05);
  const auto id = analysis::identify(data, kind, *hand, model.motion, model.sensor);
  const json configured = configured_values(session, kind, *hand, hand_damping, hand_stiffness);

  json result{{"plant", std::string(analysis::to_string(kind))},
              {"hand", std::string(analysis::to_string(*hand))},
              {"hand_script", hand_text},
              {"bins", data.size()},
              {"sweeps_averaged", data.sweeps},
              {"fit_error", id.fit_error},
              {"delay_periods", id.delay_periods},
              {"parameters", json::array()},
              {"confounded", json::array()},
              {"notes", id.notes},
              {"configured", configured},
              {"complete", id.complete},
              {"restored", restored}};
  for (const auto& p : id.parameters) {
    result["parameters"].push_back({{"name", p.name},
                                    {"value", p.value},
                                    {"half_width", p.half_width},
                                    {"unit", p.unit},
                                    {"note", p.note}});
  }
  for (const auto& c : id.confounded) {
    result["confounded"].push_back({{"first", c.first},
                                    {"second", c.second},
                                    {"correlation", c.correlation},
                                    {"sum_name", c.sum_name},
                                    {"sum", c.sum},
                                    {"sum_half_width", c.sum_half_width}});
  }
  const std::string subtitle = std::string(analysis::to_string(kind)) + " model, hand " + args.hand + ", " +
                               session.driver() + ", T = " + world::units::format_duration(model.period_s);
  FigureWriter writer(files);
  for (const Figure& fig : response_figures(data, id, u, subtitle)) writer.write(fig);
  std::filesystem::path model_path;
  nlohmann::ordered_json keys;
  if (id.complete) {
    keys = model_keys(id, session);
    model_path =
        args.model_file.empty() ? files.dir() / "device-model.toml" : std::filesystem::path(args.model_file);
    model_path = std::filesystem::absolute(model_path).lexically_normal();
    const std::string how = std::to_string(args.sweeps) + " sweeps " + fmt(f0) + "-" + fmt(f1) + " Hz of " +
                            fmt(amplitude) + " " + u.force + " on " + session.driver() + ", hand " +
                            args.hand;
    result["model_file"] = model_path.string();
    result["model"] = json(keys);
    std::ofstream out(model_path);
    out << model_file_text(id, keys, how);
    if (!out) throw std::runtime_error("cannot write the model file " + model_path.string());
  }
  files.stage("identification.json", result.dump(1) + "\n");
  const auto written = files.commit();
  json applied;
  if (args.apply) {
    applied = session.call("device.model.set", {{"model", json(keys)}, {"file", model_path.string()}});
    result["applied"] = applied;
  }
  if (opts.json) {
    hapticctl::detail::print_json(result);
    return exit_ok;
  }
  std::cout << "identify " << analysis::to_string(kind) << " on " << session.driver() << " (" << model.summary
            << ", model from " << model.source << "), " << hand_text << "\n";
  print_identification(id, configured, result);
  writer.report_problems(files.dir());
  std::cout << restored << "\n" << written.size() << " files in " << files.dir().string() << "\n";
  if (!model_path.empty()) std::cout << "model file: " << model_path.string() << "\n";
  if (args.apply) {
    std::cout << "applied: the stability gate now uses " << applied["model"].value("summary", std::string())
              << " (" << applied["model"].value("source", std::string()) << ")\n"
              << "scene " << applied["scene"].value("name", std::string()) << ": "
              << applied["scene"]["stability"].value("summary", std::string()) << "\n"
              << "name the file in the config to keep it: [device] model = \"" << model_path.string()
              << "\"\n";
  }
  return exit_ok;
}

}  // namespace

void add_identify_command(CLI::App& app, hapticctl::CommonOptions& opts) {
  auto args = std::make_shared<IdentifyArgs>();
  auto* cmd = app.add_subcommand(
      "identify", "Identify the device model from a chirp on the running device (needs hapticd)");
  hapticctl::add_common_options(*cmd, opts);
  cmd->add_option("--plant", args->plant, "rigid or two-mass (default: the kind of the model in force)");
  cmd->add_option(
      "--hand", args->hand,
      "free, hold (still) or spring: how the device is held (scripted on the loopback; default free)");
  cmd->add_option("--hand-stiffness", args->hand_stiffness,
                  "loopback, --hand spring: the hand's stiffness, N/m (N m/rad); default 1 Hz on the mass");
  cmd->add_option("--hand-damping", args->hand_damping,
                  "loopback, --hand spring: the hand's damping (default 0)");
  cmd->add_option("--amplitude", args->amplitude,
                  "chirp force amplitude, N (N m); default half the torque limit");
  cmd->add_option("--start-frequency", args->start_frequency, "sweep start, Hz (default 0.5)");
  cmd->add_option("--end-frequency", args->end_frequency,
                  "sweep end, Hz (default 50 rigid, 200 two-mass, at most 0.4/T)");
  cmd->add_option("--sweep", args->sweep, "one sweep (s, ms; default 20s)");
  cmd->add_option("--sweeps", args->sweeps, "sweeps; the first is the transient, dropped (default 3)")
      ->check(CLI::Range(2, 100));
  cmd->add_option("--out", args->out,
                  "directory for the figures and identification.json (default hapticd-identify)");
  cmd->add_option("--model-file", args->model_file,
                  "where to write the model (default OUT/device-model.toml)");
  cmd->add_flag(
      "--apply", args->apply,
      "make the identified model the one the stability gate uses for this device (device.model.set)");
  cmd->add_flag("--keep-recordings", args->keep_recordings, "keep the daemon's recording of the run");
  cmd->callback([&opts, args] {
    int code = exit_ok;
    try {
      code = run_identify(opts, *args);
    } catch (const std::invalid_argument& e) {
      std::cerr << "hapticctl: identify: " << e.what() << "\n";
      code = exit_refused;
    }
    if (code != exit_ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli
