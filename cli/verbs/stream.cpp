// hapticctl stream [--rate HZ] [--count N] [CHANNEL ...]: live telemetry.
// On a terminal one line refreshes in place; otherwise one line per sample.

#include <csignal>
#include <iostream>

#include <unistd.h>

#include "cli/verbs.hpp"

namespace hapticctl {

namespace {
volatile std::sig_atomic_t interrupted = 0;
extern "C" void on_interrupt(int) { interrupted = 1; }

std::string sample_line(const nlohmann::json& params) {
  std::string line;
  auto add = [&line](const std::string& key, const nlohmann::json& value) {
    line += (line.empty() ? "" : "  ") + detail::display_key(key) + " " + detail::format_value(key, value);
  };
  // A telemetry notification: cycle, time_s, the channels, seq and dropped.
  for (const auto& [key, value] : params.items()) {
    if (key == "seq" || key == "dropped") continue;
    if (!value.is_structured()) add(key, value);
  }
  if (params.value("dropped", 0) > 0) add("dropped", params["dropped"]);
  return line;
}

struct StreamArgs {
  double rate_hz = 10.0;
  long count = 0;
  std::vector<std::string> channels;
};

/// --timeout is the longest silence accepted: a rate whose period is not
/// shorter would always run into it.
void check_rate_within_timeout(const StreamArgs& args, const CommonOptions& opts) {
  const double period_s = 1.0 / args.rate_hz;
  if (!(period_s < opts.timeout_s)) {
    std::cerr << "hapticctl: stream: --rate " << detail::scalar(args.rate_hz) << " Hz sends a sample every "
              << detail::scalar(period_s) << " s, not within --timeout " << detail::scalar(opts.timeout_s)
              << " s; raise --timeout above " << detail::scalar(period_s) << " or the rate\n";
    throw Exit(exit_code::usage);
  }
}

/// SIGINT's and SIGTERM's actions before the stream took them.
struct SavedStopSignals {
  struct sigaction int_action {};
  struct sigaction term_action {};
};

/// Ctrl-C and SIGTERM end the stream after the sample being read.
SavedStopSignals catch_stop_signals() {
  interrupted = 0;
  struct sigaction sa {};
  sa.sa_handler = on_interrupt;  // no SA_RESTART: poll() returns EINTR
  sigemptyset(&sa.sa_mask);
  SavedStopSignals saved;
  ::sigaction(SIGINT, &sa, &saved.int_action);
  ::sigaction(SIGTERM, &sa, &saved.term_action);
  return saved;
}

void restore_stop_signals(const SavedStopSignals& saved) {
  ::sigaction(SIGINT, &saved.int_action, nullptr);
  ::sigaction(SIGTERM, &saved.term_action, nullptr);
}

/// One sample: JSON, a line refreshed in place on a terminal, or a line of its own.
void print_sample(const nlohmann::json& params, bool as_json, bool tty) {
  if (as_json) {
    std::cout << params.dump() << '\n' << std::flush;
  } else if (tty) {
    std::cout << '\r' << sample_line(params) << "\x1b[K" << std::flush;
  } else {
    std::cout << sample_line(params) << '\n' << std::flush;
  }
}

/// Prints samples until --count, Ctrl-C or SIGTERM, or a silence longer than
/// --timeout; true when it ended on that silence (said on stderr).
bool stream_samples(hapticd::client::Client& client, const StreamArgs& args, const CommonOptions& opts,
                    bool tty, long& received) {
  const std::chrono::duration<double> patience(opts.timeout_s);
  auto last = std::chrono::steady_clock::now();
  while (interrupted == 0 && (args.count == 0 || received < args.count)) {
    auto n = client.read_notification(std::chrono::milliseconds(200));
    if (!n) {
      if (std::chrono::steady_clock::now() - last > patience) {
        std::cerr << (tty && received > 0 ? "\n" : "") << "hapticctl: no telemetry from hapticd for "
                  << opts.timeout_s << " s\n";
        return true;
      }
      continue;
    }
    last = std::chrono::steady_clock::now();
    if (n->value("method", std::string()) != hapticd::rpc::telemetry_method) continue;
    const auto& params = (*n)["params"];
    ++received;
    print_sample(params, opts.json, tty);
  }
  return false;
}

void run_stream(const StreamArgs& args, const CommonOptions& opts) {
  check_rate_within_timeout(args, opts);
  auto client = detail::connect(opts);
  const SavedStopSignals saved = catch_stop_signals();
  const bool tty = ::isatty(STDOUT_FILENO) == 1 && !opts.json;
  long received = 0;
  bool ended_on_error = false;
  try {
    client.subscribe(args.rate_hz, args.channels);
    ended_on_error = stream_samples(client, args, opts, tty, received);
    if (tty && received > 0) std::cout << '\n';
    try {
      client.unsubscribe();
    } catch (const std::exception&) {
      // The daemon ends the stream with the connection anyway.
    }
  } catch (const Exit&) {
    throw;
  } catch (...) {
    if (tty && received > 0) std::cout << '\n';
    restore_stop_signals(saved);
    detail::exit_for_current_exception("stream");
  }
  restore_stop_signals(saved);
  if (ended_on_error) throw Exit(exit_code::unreachable);
}
}  // namespace

void add_stream_command(CLI::App& app, CommonOptions& opts) {
  auto args = std::make_shared<StreamArgs>();
  auto* cmd = app.add_subcommand("stream", "show live telemetry until Ctrl-C (or --count samples)");
  add_common_options(*cmd, opts);
  cmd->add_option("--rate", args->rate_hz, "samples per second (hapticd streams 0.1 to 1000)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--count", args->count, "stop after N samples (0: until interrupted)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("channels", args->channels, "channels to show (default: the daemon's set)");
  cmd->callback([&opts, args] { run_stream(*args, opts); });
}

}  // namespace hapticctl
