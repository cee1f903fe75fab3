// The session of an experiment through the running daemon (see the header).

#include "cli/experiment_session.hpp"

#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "client/socket_path.hpp"

namespace hapticd::cli {

namespace {

volatile std::sig_atomic_t interrupt_flag = 0;
extern "C" void on_experiment_interrupt(int) { interrupt_flag = 1; }
struct sigaction previous_int {
}, previous_term{};

using nlohmann::json;

Eigen::MatrixXd matrix(const json& rows) {
  if (!rows.is_array() || rows.empty()) return Eigen::MatrixXd(0, 0);
  Eigen::MatrixXd m(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(rows[0].size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (std::size_t j = 0; j < rows[i].size(); ++j) {
      m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = rows[i][j].get<double>();
    }
  }
  return m;
}

Eigen::RowVectorXd row(const json& values) {
  Eigen::RowVectorXd v(static_cast<Eigen::Index>(values.size()));
  for (std::size_t j = 0; j < values.size(); ++j) v(static_cast<Eigen::Index>(j)) = values[j].get<double>();
  return v;
}

DaemonModel model_from(const json& m) {
  DaemonModel out;
  out.json = m;
  out.motion =
      m.value("motion", std::string("linear")) == "rotary" ? world::Motion::rotary : world::Motion::linear;
  out.period_s = m.at("period_s").get<double>();
  out.delay_periods = m.value("delay_periods", 0);
  out.resolution = m.value("position_resolution", 0.0);
  out.effective_mass = m.value("effective_mass", 0.0);
  out.sensor = world::parse_sensor(m.value("sensor", std::string("motor"))).value_or(world::Sensor::motor);
  out.source = m.value("source", std::string());
  out.summary = m.value("summary", std::string());
  const json& ss = m.at("state_space");
  out.plant.dynamics.a = matrix(ss.at("a"));
  out.plant.dynamics.b = matrix(ss.at("b"));
  out.plant.motor_position = row(ss.at("motor_position"));
  out.plant.body_position = row(ss.at("body_position"));
  out.two_mass = out.plant.dynamics.a.rows() == 4;
  return out;
}

/// Index of the first column whose name starts with `prefix` ("position_" in "position_m").
std::optional<std::size_t> column_starting(const std::vector<std::string>& columns, std::string_view prefix) {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == prefix || columns[i].starts_with(std::string(prefix) + "_")) return i;
  }
  return std::nullopt;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) out.push_back(cell);
  return out;
}

}  // namespace

MotionUnits units_of(world::Motion motion) {
  if (motion == world::Motion::rotary) return {"rad", "N m", "N m/rad"};
  return {"m", "N", "N/m"};
}

std::vector<RecordedSample> read_recorded(const std::filesystem::path& file, std::uint64_t first,
                                          std::uint64_t last) {
  std::ifstream in(file);
  if (!in) {
    throw std::runtime_error(
        "cannot read the recording " + file.string() +
        " (hapticctl reads the daemon's recording directory: run it on the same host, as a "
        "user who may read it)");
  }
  std::vector<RecordedSample> out;
  std::optional<std::size_t> cycle, position, force;
  std::size_t width = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (line.starts_with("time_s,")) {  // a section's column line
      const auto columns = split(line);
      width = columns.size();
      cycle = column_starting(columns, "cycle");
      position = column_starting(columns, "position");
      force = column_starting(columns, "applied");
      continue;
    }
    if (!cycle || !position || !force) {
      throw std::runtime_error(file.string() + ": no cycle, position and applied columns");
    }
    const auto cells = split(line);
    if (cells.size() != width) continue;  // a row cut by a full disk
    const auto c = static_cast<std::uint64_t>(std::stoull(cells[*cycle]));
    if (c < first || c >= last) continue;
    out.push_back({c, std::stod(cells[*position]), std::stod(cells[*force])});
  }
  return out;
}

ExperimentSession::ExperimentSession(const hapticctl::CommonOptions& options) : options_(options) {
  client_.emplace(hapticctl::detail::connect(options_));
  const json s = call("status");
  torque_limit_ = s.at("torque_limit").get<double>();
  scene_name_ = s.at("scene").at("name").get<std::string>();
  scene_parameters_ = s.at("scene").at("parameters");
  scene_forced_ = s.at("scene").value("forced", false);
  driver_ = s.at("device").value("driver", std::string());
  model_ = model_from(call("device.model"));
  driver_values_ = call("device.describe").value("values", json::object());
  interrupt_flag = 0;
  struct sigaction action {};
  action.sa_handler = on_experiment_interrupt;  // no SA_RESTART: a waiting poll() returns
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, &previous_int);
  ::sigaction(SIGTERM, &action, &previous_term);
}

ExperimentSession::~ExperimentSession() {
  try {
    const std::string done = restore();
    if (!done.empty()) std::cerr << "hapticctl: " << done << "\n";
  } catch (const hapticctl::Exit&) {
    std::cerr << "hapticctl: could not restore the scene " << scene_name_ << " (reason above)\n";
  } catch (const std::exception& e) {
    std::cerr << "hapticctl: could not restore the scene " << scene_name_ << ": " << e.what() << "\n";
  }
  ::sigaction(SIGINT, &previous_int, nullptr);
  ::sigaction(SIGTERM, &previous_term, nullptr);
}

bool ExperimentSession::interrupted() noexcept { return interrupt_flag != 0; }

json ExperimentSession::call(const std::string& method, const json& params) {
  try {
    return client_->call(method, params);
  } catch (...) {
    hapticctl::detail::exit_for_current_exception(method);
  }
}

std::optional<std::string> ExperimentSession::set_hand(const json& script) {
  try {
    const json reply = client_->call("hand.set", script);
    hand_set_ = changed_ = true;
    return reply.value("hand", std::string());
  } catch (const rpc::RpcError& e) {
    if (e.code() == rpc::code::method_not_found) return std::nullopt;
    hapticctl::detail::exit_for_current_exception("hand.set");
  } catch (...) {
    hapticctl::detail::exit_for_current_exception("hand.set");
  }
}

double ExperimentSession::position() {
  const json s = status();
  if (!s.contains("last")) throw std::runtime_error("hapticd has no sample yet");
  return s["last"].at("position").get<double>();
}

std::uint64_t ExperimentSession::load(const std::string& scene, const json& parameters) {
  changed_ = true;  // before the call: a load that fails half-way is undone too
  const json reply = call("scene.load", {{"scene", scene}, {"params", parameters}});
  return reply.at("effective_cycle").get<std::uint64_t>();
}

std::filesystem::path ExperimentSession::start_recording(const std::string& name) {
  const json reply = call("record.start", {{"path", name}});
  recording_ = changed_ = true;
  return reply.value("file", reply.value("path", std::string()));
}

std::filesystem::path ExperimentSession::stop_recording() {
  const json reply = call("record.stop");
  recording_ = false;
  return reply.value("file", reply.value("path", std::string()));
}

void ExperimentSession::wait_for_cycle(std::uint64_t cycle) {
  std::uint64_t last = 0;
  auto since = std::chrono::steady_clock::now();
  for (;;) {
    if (interrupted()) throw Interrupted();
    const json s = status();
    const auto now = s.at("cycle").get<std::uint64_t>();
    if (now > cycle) return;
    if (s.value("state", std::string()) == "stopped") {
      throw std::runtime_error("hapticd's loop stopped at cycle " + std::to_string(now));
    }
    if (now != last) {
      last = now;
      since = std::chrono::steady_clock::now();
    } else if (std::chrono::steady_clock::now() - since > std::chrono::duration<double>(options_.timeout_s)) {
      throw std::runtime_error("hapticd's loop has not advanced for " + std::to_string(options_.timeout_s) +
                               " s (cycle " + std::to_string(now) + ")");
    }
    // A tenth of the remaining time, between 2 and 50 ms: the virtual clock
    // runs thousands of periods between two polls anyway.
    const double left_s = static_cast<double>(cycle - now) * model_.period_s;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::clamp(0.1 * left_s, 0.002, 0.05)));
  }
}

std::string ExperimentSession::restore() {
  if (restored_ || !changed_) return {};
  restored_ = true;
  std::string done;
  if (recording_) {
    stop_recording();
    done = "recording stopped; ";
  }
  json params{{"scene", scene_name_}, {"params", scene_parameters_}};
  if (scene_forced_) params["force"] = true;
  call("scene.load", params);
  done += "scene " + scene_name_ + " restored";
  if (hand_set_) {
    call("hand.set", {{"mode", "free"}});
    done += ", the simulated hand set free";
  }
  return done;
}

}  // namespace hapticd::cli
