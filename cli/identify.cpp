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

/// The chirp and the hand, as the flags and the daemon's model set them.
struct ChirpPlan {
  HandCondition hand = HandCondition::free;
  IdentifiedPlant kind = IdentifiedPlant::rigid;
  double start_hz = 0.0;
  double end_hz = 0.0;
  double sweep_s = 0.0;
  double amplitude = 0.0;
  double hand_damping = 0.0;
  std::optional<double> hand_stiffness;  ///< --hand spring only
  std::int64_t sweep_steps = 0;          ///< one sweep, in loop periods
  double duration_s = 0.0;               ///< the whole scene: every sweep and one start period more
};

/// The flags that need no daemon, checked before it is reached.
ChirpPlan check_identify_flags(const IdentifyArgs& args) {
  const auto hand = analysis::parse_hand_condition(args.hand);
  if (!hand) throw UsageError("--hand: '" + args.hand + "' is not accepted; free, hold or spring");
  ChirpPlan plan;
  plan.hand = *hand;
  plan.start_hz = positive("--start-frequency", args.start_frequency);
  const auto sweep_s = world::units::parse_duration_s(args.sweep);
  if (!sweep_s || !(*sweep_s > 0.0)) throw UsageError("--sweep: '" + args.sweep + "' is not a duration > 0");
  plan.sweep_s = *sweep_s;
  if (args.apply && plan.hand != HandCondition::free) {
    throw UsageError(
        "--apply needs --hand free: held or on a spring, the run does not give the device's model");
  }
  plan.hand_damping = positive("--hand-damping", args.hand_damping, true);
  return plan;
}

/// The flags checked against the device: the model kind, the band up to
/// Nyquist, the force within the torque limit, the hand's spring.
void fit_chirp_to_device(ChirpPlan& plan, const IdentifyArgs& args, const ExperimentSession& session,
                         const MotionUnits& u) {
  const DaemonModel& model = session.model();
  plan.kind = model.two_mass ? IdentifiedPlant::two_mass : IdentifiedPlant::rigid;
  if (!args.plant.empty()) {
    const auto parsed = analysis::parse_identified_plant(args.plant);
    if (!parsed) throw UsageError("--plant: '" + args.plant + "' is not accepted; rigid or two-mass");
    plan.kind = *parsed;
  }
  const double nyquist = 0.5 / model.period_s;
  plan.end_hz = args.end_frequency.empty()
                    ? std::min(plan.kind == IdentifiedPlant::rigid ? 50.0 : 200.0, 0.4 / model.period_s)
                    : positive("--end-frequency", args.end_frequency);
  if (!(plan.end_hz > plan.start_hz && plan.end_hz <= nyquist)) {
    throw UsageError("--end-frequency " + fmt(plan.end_hz) +
                     " Hz must lie above --start-frequency and at most at 1/(2T) = " + fmt(nyquist) + " Hz");
  }
  plan.amplitude =
      args.amplitude.empty() ? 0.5 * session.torque_limit() : positive("--amplitude", args.amplitude);
  if (plan.amplitude > session.torque_limit()) {
    throw UsageError("--amplitude " + fmt(plan.amplitude) + " " + u.force +
                     " is above the daemon's torque limit " + fmt(session.torque_limit()) + " " + u.force);
  }
  if (plan.hand == HandCondition::spring) {
    plan.hand_stiffness =
        args.hand_stiffness.empty()
            ? model.effective_mass * std::pow(2.0 * std::numbers::pi * 1.0, 2)  // 1 Hz on the mass
            : positive("--hand-stiffness", args.hand_stiffness);
  }
  plan.sweep_steps = static_cast<std::int64_t>(std::llround(plan.sweep_s / model.period_s));
  plan.duration_s =
      static_cast<double>(args.sweeps) * static_cast<double>(plan.sweep_steps) * model.period_s +
      1.0 / plan.start_hz;
}

/// The loopback's hand.set script for the planned hand, holding it at y0.
json hand_script_json(const ChirpPlan& plan, double y0) {
  json script{{"mode", "free"}};
  if (plan.hand == HandCondition::hold) script = {{"mode", "hold"}, {"position", y0}};
  if (plan.hand == HandCondition::spring) {
    script = {{"mode", "impedance"},
              {"stiffness", *plan.hand_stiffness},
              {"damping", plan.hand_damping},
              {"position", y0}};
  }
  return script;
}

/// What the chirp recorded, and how the hand was held.
struct ChirpRecording {
  std::vector<RecordedSample> rows;
  std::string hand_text;
};

/// Holds the hand as planned, plays the chirp scene to its end and reads its
/// sweeps back from the daemon's recording.
ChirpRecording record_chirp(ExperimentSession& session, const IdentifyArgs& args, const ChirpPlan& plan,
                            const MotionUnits& u) {
  const double period_s = session.model().period_s;
  ChirpRecording recording;
  const auto set = session.set_hand(hand_script_json(plan, session.position()));
  recording.hand_text = set ? "simulated hand: " + *set : "hand: " + args.hand + " (as you hold the device)";
  const std::string name = "hapticctl-identify-" + std::to_string(::getpid()) + ".csv";
  const auto file = session.start_recording(name);
  const std::uint64_t c0 = session.load("chirp", {{"amplitude", plan.amplitude},
                                                  {"start_frequency", plan.start_hz},
                                                  {"end_frequency", plan.end_hz},
                                                  {"sweep", static_cast<double>(plan.sweep_steps) * period_s},
                                                  {"duration", plan.duration_s}});
  const auto end = c0 + static_cast<std::uint64_t>(args.sweeps * plan.sweep_steps);
  std::cerr << "hapticctl: identify: " << args.sweeps << " sweeps of " << fmt(plan.sweep_s) << " s, "
            << fmt(plan.amplitude) << " " << u.force << " from " << fmt(plan.start_hz) << " to "
            << fmt(plan.end_hz) << " Hz; " << recording.hand_text << "\n";
  session.wait_for_cycle(c0 + static_cast<std::uint64_t>(std::llround(plan.duration_s / period_s)));
  session.stop_recording();
  recording.rows = read_recorded(file, c0, end);
  if (!args.keep_recordings) {
    std::error_code ignored;
    std::filesystem::remove(file, ignored);
  }
  return recording;
}

/// The averaged frequency response of the recorded sweeps, the band's edges left out.
analysis::FrequencyResponse measure_chirp_response(const std::vector<RecordedSample>& rows,
                                                   const ChirpPlan& plan, double period_s) {
  std::vector<double> y, f;
  for (const auto& r : rows) {
    y.push_back(r.position);
    f.push_back(r.force);
  }
  return analysis::measure_frequency_response(y, f, period_s, plan.sweep_steps, plan.start_hz * 1.05,
                                              plan.end_hz / 1.05);
}

/// identification.json (and --json's output) before the model file and --apply.
json identification_json(const ChirpPlan& plan, const std::string& hand_text,
                         const analysis::FrequencyResponse& data, const analysis::Identification& id,
                         const json& configured, const std::string& restored) {
  json result{{"plant", std::string(analysis::to_string(plan.kind))},
              {"hand", std::string(analysis::to_string(plan.hand))},
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
  return result;
}

/// The model file written, and its [model] keys (both empty when the fit was not complete).
struct WrittenModel {
  std::filesystem::path path;
  nlohmann::ordered_json keys;
};

/// Writes the identified model where --model-file says (OUT/device-model.toml
/// by default) and names it in the result.
WrittenModel write_model_file(const analysis::Identification& id, const ExperimentSession& session,
                              const IdentifyArgs& args, const ChirpPlan& plan, const MotionUnits& u,
                              const StagedFiles& files, json& result) {
  WrittenModel model;
  model.keys = model_keys(id, session);
  model.path =
      args.model_file.empty() ? files.dir() / "device-model.toml" : std::filesystem::path(args.model_file);
  model.path = std::filesystem::absolute(model.path).lexically_normal();
  const std::string how = std::to_string(args.sweeps) + " sweeps " + fmt(plan.start_hz) + "-" +
                          fmt(plan.end_hz) + " Hz of " + fmt(plan.amplitude) + " " + u.force + " on " +
                          session.driver() + ", hand " + args.hand;
  result["model_file"] = model.path.string();
  result["model"] = json(model.keys);
  std::ofstream out(model.path);
  out << model_file_text(id, model.keys, how);
  if (!out) throw std::runtime_error("cannot write the model file " + model.path.string());
  return model;
}

/// What --apply did: the gate's model now, and the loaded scene's verdict on it.
void print_applied_model(const json& applied, const std::filesystem::path& model_path) {
  std::cout << "applied: the stability gate now uses " << applied["model"].value("summary", std::string())
            << " (" << applied["model"].value("source", std::string()) << ")\n"
            << "scene " << applied["scene"].value("name", std::string()) << ": "
            << applied["scene"]["stability"].value("summary", std::string()) << "\n"
            << "name the file in the config to keep it: [device] model = \"" << model_path.string() << "\"\n";
}

/// Fits the model to the recording, writes the figures, identification.json
/// and the model file, applies the model with --apply, and prints the result.
int report_identification(const hapticctl::CommonOptions& opts, const IdentifyArgs& args,
                          ExperimentSession& session, const ChirpPlan& plan, const ChirpRecording& recording,
                          const std::string& restored, StagedFiles& files) {
  const DaemonModel& model = session.model();
  const MotionUnits u = units_of(model.motion);
  const auto data = measure_chirp_response(recording.rows, plan, model.period_s);
  const auto id = analysis::identify(data, plan.kind, plan.hand, model.motion, model.sensor);
  const json configured =
      configured_values(session, plan.kind, plan.hand, plan.hand_damping, plan.hand_stiffness);
  json result = identification_json(plan, recording.hand_text, data, id, configured, restored);
  const std::string subtitle = std::string(analysis::to_string(plan.kind)) + " model, hand " + args.hand +
                               ", " + session.driver() +
                               ", T = " + world::units::format_duration(model.period_s);
  FigureWriter writer(files);
  for (const Figure& fig : response_figures(data, id, u, subtitle)) writer.write(fig);
  const WrittenModel written_model =
      id.complete ? write_model_file(id, session, args, plan, u, files, result) : WrittenModel{};
  files.stage("identification.json", result.dump(1) + "\n");
  const auto written = files.commit();
  json applied;
  if (args.apply) {
    applied = session.call("device.model.set",
                           {{"model", json(written_model.keys)}, {"file", written_model.path.string()}});
    result["applied"] = applied;
  }
  if (opts.json) {
    hapticctl::detail::print_json(result);
    return exit_ok;
  }
  std::cout << "identify " << analysis::to_string(plan.kind) << " on " << session.driver() << " ("
            << model.summary << ", model from " << model.source << "), " << recording.hand_text << "\n";
  print_identification(id, configured, result);
  writer.report_problems(files.dir());
  std::cout << restored << "\n" << written.size() << " files in " << files.dir().string() << "\n";
  if (!written_model.path.empty()) std::cout << "model file: " << written_model.path.string() << "\n";
  if (args.apply) print_applied_model(applied, written_model.path);
  return exit_ok;
}

int run_identify(const hapticctl::CommonOptions& opts, const IdentifyArgs& args) {
  ChirpPlan plan = check_identify_flags(args);
  StagedFiles files = open_output(args.out);
  ExperimentSession session(opts);
  const MotionUnits u = units_of(session.model().motion);
  fit_chirp_to_device(plan, args, session, u);
  ChirpRecording recording;
  try {
    recording = record_chirp(session, args, plan, u);
  } catch (const Interrupted&) {
    std::cerr << "hapticctl: identify stopped by Ctrl-C; " << session.restore() << "; nothing written\n";
    return exit_experiment_interrupted;
  }
  const std::string restored = session.restore();
  return report_identification(opts, args, session, plan, recording, restored, files);
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
