// hapticctl scope [--port N] [--no-browser] [--rate HZ]: a read-only web page
// on 127.0.0.1 fed by the daemon's stream (docs/scope.md). cpp-httplib
// serves the page, Debian's dygraphs and one server-sent-event stream per
// page; this thread feeds that stream from the daemon's `stream`, `status`
// and `telemetry.get` (read access only: changing anything stays in the
// other verbs, where the daemon checks who asks).

#include "cli/scope/scope.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>
#include <system_error>
#include <thread>

#include <httplib.h>

#include "cli/scope/event_hub.hpp"
#include "client/socket_path.hpp"

extern char** environ;

namespace hapticd::cli::scope {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

volatile std::sig_atomic_t interrupted = 0;
extern "C" void scope_on_interrupt(int) { interrupted = 1; }

struct Args {
  int port = 0;
  bool no_browser = false;
  double rate_hz = 200.0;
};

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return in ? text.str() : std::string();
}

/// The daemon's channels with units, the period and the scene: what the
/// page needs before the first sample.
json meta_of(hapticd::client::Client& client, double rate_hz) {
  json meta{{"rate_hz", rate_hz}, {"socket", client.path()}};
  try {
    meta["channels"] = client.call("telemetry.get").value("available", json::array());
  } catch (const hapticd::client::RpcError&) {
    meta["channels"] = json::array();  // a daemon without telemetry.get: names only, from the samples
  }
  return meta;
}

/// One connection's life: meta, then samples and a status every half second,
/// until interrupted or the connection fails (thrown).
void feed(EventHub& hub, const std::string& path, const Args& args, std::chrono::milliseconds timeout) {
  auto client = hapticd::client::Client::connect(path, timeout);
  hub.publish("meta", meta_of(client, args.rate_hz).dump(), true);
  auto publish_status = [&] {
    json status = client.call("status");
    status["reachable"] = true;
    hub.publish("status", status.dump(), true);
  };
  publish_status();
  client.subscribe(args.rate_hz);
  auto next_status = Clock::now() + std::chrono::milliseconds(500);
  auto last_sample = Clock::now();
  while (interrupted == 0) {
    if (auto n = client.read_notification(std::chrono::milliseconds(100))) {
      if (n->value("method", std::string()) == hapticd::rpc::telemetry_method) {
        hub.publish("sample", (*n)["params"].dump());
        last_sample = Clock::now();
      }
    }
    if (Clock::now() >= next_status) {
      publish_status();
      next_status = Clock::now() + std::chrono::milliseconds(500);
    }
    if (Clock::now() - last_sample > timeout)
      throw hapticd::client::ConnectError("no telemetry from hapticd", path, 0);
  }
}

void feed_until_interrupted(EventHub& hub, const std::string& path, const Args& args,
                            std::chrono::milliseconds timeout) {
  while (interrupted == 0) {
    std::string error;
    try {
      feed(hub, path, args, timeout);
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (interrupted != 0) break;
    // The page says so and keeps its data; we try again every second.
    hub.publish("status", json{{"reachable", false}, {"error", error}, {"socket", path}}.dump(), true);
    for (int i = 0; i < 10 && interrupted == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void open_browser(const std::string& url) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  std::string program = "xdg-open";
  char* argv[] = {program.data(), const_cast<char*>(url.c_str()), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "xdg-open", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    std::cerr << "hapticctl: scope: cannot start xdg-open (" << std::generic_category().message(rc)
              << "); open " << url << " in a browser\n";
    return;
  }
  std::thread([pid] {
    int status = 0;
    ::waitpid(pid, &status, 0);
  }).detach();
}

void serve_files(httplib::Server& server, EventHub& hub) {
  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(std::string(page_html()), "text/html; charset=utf-8");
  });
  for (const char* name : {"dygraph.min.js", "dygraph.min.css"}) {
    const std::string text = read_file(std::string(HAPTICD_DYGRAPHS_DIR) + "/" + name);
    const bool js = std::string_view(name).ends_with(".js");
    server.Get(std::string("/") + name, [text, js](const httplib::Request&, httplib::Response& res) {
      res.set_content(text, js ? "text/javascript" : "text/css");
    });
  }
  server.Get("/favicon.ico", [](const httplib::Request&, httplib::Response& res) { res.status = 204; });
  server.Get("/events", [&hub](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    auto next = std::make_shared<std::uint64_t>(0);
    auto joined = std::make_shared<bool>(false);
    res.set_chunked_content_provider("text/event-stream",
                                     [&hub, next, joined](std::size_t, httplib::DataSink& sink) {
                                       std::string out;
                                       if (!*joined) {
                                         out = "retry: 1000\n\n" + hub.join(*next);
                                         *joined = true;
                                       } else {
                                         auto more = hub.read(*next, std::chrono::milliseconds(1000));
                                         if (!more) return false;  // closing
                                         out = more->empty() ? ": keep-alive\n\n" : *more;
                                       }
                                       return sink.write(out.data(), out.size());
                                     });
  });
}

int run_scope(const hapticctl::CommonOptions& opts, const Args& args) {
  const std::string dygraphs = std::string(HAPTICD_DYGRAPHS_DIR) + "/dygraph.min.js";
  if (read_file(dygraphs).empty()) {
    std::cerr << "hapticctl: scope: cannot read " << dygraphs << " (Debian package libjs-dygraphs)\n";
    return hapticctl::exit_code::refused;
  }
  const std::string path = hapticd::client::resolve_client_socket_path(opts.socket, opts.instance);
  const auto timeout = std::chrono::milliseconds(static_cast<long long>(std::ceil(opts.timeout_s * 1000.0)));
  // A minute of samples for a page that connects late, plus the statuses.
  EventHub hub(static_cast<std::size_t>(args.rate_hz * 60.0) + 256);
  httplib::Server server;
  serve_files(server, hub);
  const int port = args.port == 0 ? server.bind_to_any_port("127.0.0.1")
                                  : (server.bind_to_port("127.0.0.1", args.port) ? args.port : -1);
  if (port < 0) {
    std::cerr << "hapticctl: scope: cannot listen on 127.0.0.1:" << args.port
              << " (in use?); --port 0 or none takes a free one\n";
    return hapticctl::exit_code::refused;
  }
  std::thread listener([&server] { server.listen_after_bind(); });
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  std::cout << "hapticctl scope: " << url << " (read-only; Ctrl-C stops)" << std::endl;
  if (!args.no_browser) open_browser(url);

  interrupted = 0;
  struct sigaction sa {};
  sa.sa_handler = scope_on_interrupt;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  feed_until_interrupted(hub, path, args, timeout);
  hub.close();
  server.stop();
  listener.join();
  return hapticctl::exit_code::ok;
}

}  // namespace

void add_scope_command(CLI::App& app, hapticctl::CommonOptions& opts) {
  auto args = std::make_shared<Args>();
  auto* cmd =
      app.add_subcommand("scope",
                         "a live, read-only web page of the daemon on 127.0.0.1: channels against time, "
                         "the scene, its stability verdict, the fault state");
  hapticctl::add_common_options(*cmd, opts);
  cmd->add_option("--port", args->port, "port on 127.0.0.1 (default: a free one, printed)")
      ->check(CLI::Range(0, 65535));
  cmd->add_flag("--no-browser", args->no_browser, "only print the URL (default: open it with xdg-open)");
  cmd->add_option("--rate", args->rate_hz, "samples per second from the daemon (0.1 to 1000)")
      ->check(CLI::Range(0.1, 1000.0));
  cmd->callback([&opts, args] {
    const int code = run_scope(opts, *args);
    if (code != hapticctl::exit_code::ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli::scope
