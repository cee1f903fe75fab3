// hapticd_load: the control-plane load of bench/latency.sh --load. Against a
// running hapticd it keeps N clients streaming telemetry at a rate and one
// client changing a scene parameter K times a second, for a while, then says
// as JSON what came back: every param.set must be acknowledged with the
// cycle it took effect at, and what each stream got and lost.
//
// usage: hapticd_load --socket PATH [--streams 16] [--stream-rate 1000]
//          [--sets 1000] [--duration 5] [--param stiffness] [--values 1.0186,1.1]
// One thread, poll(): the load itself must stay small next to the daemon's.

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string socket;
  int streams = 16;
  double stream_rate_hz = 1000.0;
  double sets_per_second = 1000.0;
  double duration_s = 5.0;
  std::string parameter = "stiffness";
  std::vector<double> values{1.0186, 1.1};
};

[[noreturn]] void usage(const std::string& message) {
  std::cerr << "hapticd_load: " << message
            << "\nusage: hapticd_load --socket PATH [--streams N] [--stream-rate HZ] [--sets PER_S] "
               "[--duration S] [--param NAME] [--values A,B,...]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) usage(flag + " needs a value");
    const std::string value = argv[++i];
    try {
      if (flag == "--socket") {
        o.socket = value;
      } else if (flag == "--streams") {
        o.streams = std::stoi(value);
      } else if (flag == "--stream-rate") {
        o.stream_rate_hz = std::stod(value);
      } else if (flag == "--sets") {
        o.sets_per_second = std::stod(value);
      } else if (flag == "--duration") {
        o.duration_s = std::stod(value);
      } else if (flag == "--param") {
        o.parameter = value;
      } else if (flag == "--values") {
        o.values.clear();
        std::stringstream list(value);
        for (std::string item; std::getline(list, item, ',');) o.values.push_back(std::stod(item));
      } else {
        usage("unknown option " + flag);
      }
    } catch (const std::logic_error&) {
      usage(flag + " " + value + ": not a number");
    }
  }
  if (o.socket.empty()) usage("--socket is required");
  if (o.streams < 0 || o.streams > 512 || o.sets_per_second < 0 || o.duration_s <= 0 || o.values.empty())
    usage("streams 0..512, sets >= 0, duration > 0, at least one value");
  return o;
}

/// One client connection: line framing over a non-blocking socket.
class Client {
 public:
  explicit Client(const std::string& path) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path) throw std::runtime_error("socket path too long");
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw std::runtime_error("cannot connect to " + path + ": " + std::strerror(errno));
  }
  ~Client() { ::close(fd_); }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  int fd() const { return fd_; }
  void send(const json& message) {
    out_ += message.dump() + "\n";
    flush();
  }
  void flush() {
    while (!out_.empty()) {
      const ssize_t n = ::send(fd_, out_.data(), out_.size(), MSG_NOSIGNAL);
      if (n <= 0) return;
      out_.erase(0, static_cast<std::size_t>(n));
    }
  }
  bool wants_write() const { return !out_.empty(); }
  /// Reads what is there; false when the daemon closed the connection.
  bool receive() {
    char chunk[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n > 0) {
        in_.append(chunk, static_cast<std::size_t>(n));
        continue;
      }
      if (n == 0) return false;
      return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    }
  }
  /// The next complete line, or false.
  bool next_line(std::string& line) {
    const auto nl = in_.find('\n', start_);
    if (nl == std::string::npos) {
      in_.erase(0, start_);
      start_ = 0;
      return false;
    }
    line.assign(in_, start_, nl - start_);
    start_ = nl + 1;
    return true;
  }

 private:
  int fd_ = -1;
  std::string out_;
  std::string in_;
  std::size_t start_ = 0;
};

struct StreamCount {
  std::uint64_t received = 0;
  std::uint64_t dropped_by_daemon = 0;  ///< from stream.stop
  bool started = false;
  bool closed = false;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::max(1.0, std::ceil(p * static_cast<double>(v.size()))));
  return v[std::min(rank, v.size()) - 1];
}

/// The reply's id when it is a number, else 0 (a null id: busy, parse error).
std::uint64_t id_of(const json& message) {
  const auto it = message.find("id");
  return it != message.end() && it->is_number_unsigned() ? it->get<std::uint64_t>() : 0;
}

json request(std::uint64_t id, const std::string& method, json params) {
  return {{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", std::move(params)}};
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::vector<std::unique_ptr<Client>> streams;
  std::vector<StreamCount> counts(static_cast<std::size_t>(o.streams));
  std::unique_ptr<Client> setter;
  try {
    for (int i = 0; i < o.streams; ++i) {
      streams.push_back(std::make_unique<Client>(o.socket));
      streams.back()->send(request(1, "stream", {{"rate_hz", o.stream_rate_hz}}));
    }
    if (o.sets_per_second > 0) setter = std::make_unique<Client>(o.socket);
  } catch (const std::exception& e) {
    std::cerr << "hapticd_load: " << e.what() << "\n";
    return 3;
  }

  std::map<std::uint64_t, Clock::time_point> outstanding;  // param.set id -> sent at
  std::uint64_t next_id = 1, sets_sent = 0, sets_acked = 0, sets_failed = 0, sets_unnamed = 0;
  std::uint64_t last_cycle = 0, cycles_backwards = 0;
  std::vector<double> ack_ms;
  std::string first_error;
  const auto t0 = Clock::now();
  const auto send_until =
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration_s));
  const auto set_every = o.sets_per_second > 0 ? std::chrono::duration_cast<Clock::duration>(
                                                     std::chrono::duration<double>(1.0 / o.sets_per_second))
                                               : Clock::duration::max();
  auto next_set = t0;
  bool stopping = false;
  auto stop_deadline = Clock::time_point::max();

  for (;;) {
    const auto now = Clock::now();
    if (!stopping && now >= send_until) {
      stopping = true;
      stop_deadline = now + std::chrono::seconds(3);
      for (auto& s : streams) s->send(request(2, "stream.stop", json::object()));
    }
    if (stopping) {
      const bool streams_done =
          std::all_of(counts.begin(), counts.end(), [](const StreamCount& c) { return c.closed; });
      if ((streams_done && outstanding.empty()) || now >= stop_deadline) break;
    }
    // param.set on schedule, whether or not the previous reply is in (at most 64 in flight).
    while (setter && !stopping && now >= next_set && outstanding.size() < 64) {
      const double value = o.values[sets_sent % o.values.size()];
      const std::uint64_t id = next_id++;
      setter->send(request(id, "param.set", {{"params", {{o.parameter, value}}}}));
      outstanding.emplace(id, Clock::now());
      ++sets_sent;
      next_set += set_every;
    }
    std::vector<pollfd> fds;
    for (auto& s : streams)
      fds.push_back({s->fd(), static_cast<short>(POLLIN | (s->wants_write() ? POLLOUT : 0)), 0});
    if (setter)
      fds.push_back({setter->fd(), static_cast<short>(POLLIN | (setter->wants_write() ? POLLOUT : 0)), 0});
    int timeout_ms = 10;
    if (setter && !stopping) {
      const auto wait =
          std::chrono::duration_cast<std::chrono::milliseconds>(next_set - Clock::now()).count();
      timeout_ms = static_cast<int>(std::clamp<long long>(wait, 0, 10));
    }
    if (::poll(fds.data(), fds.size(), timeout_ms) < 0 && errno != EINTR) break;

    for (std::size_t i = 0; i < streams.size(); ++i) {
      auto& c = counts[i];
      if (c.closed) continue;
      if (fds[i].revents & POLLOUT) streams[i]->flush();
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const bool open = streams[i]->receive();
      std::string line;
      while (streams[i]->next_line(line)) {
        const json m = json::parse(line, nullptr, false);
        if (m.value("method", "") == "telemetry") {
          ++c.received;
        } else if (m.contains("result") && id_of(m) == 1) {
          c.started = true;
        } else if (m.contains("result") && id_of(m) == 2) {
          c.dropped_by_daemon = m["result"].value("dropped", std::uint64_t{0});
          c.closed = true;
        } else if (m.contains("error") && first_error.empty()) {
          first_error = "stream: " + m["error"].dump();
        }
      }
      if (!open) c.closed = true;
    }
    if (setter) {
      const pollfd& p = fds.back();
      if (p.revents & POLLOUT) setter->flush();
      if (p.revents & (POLLIN | POLLHUP | POLLERR)) {
        const bool open = setter->receive();
        std::string line;
        while (setter->next_line(line)) {
          const json m = json::parse(line, nullptr, false);
          const auto id = id_of(m);
          if (id == 0 && m.contains("error") && first_error.empty()) first_error = "param.set: " + m.dump();
          const auto it = outstanding.find(id);
          if (it == outstanding.end()) continue;
          ack_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - it->second).count());
          outstanding.erase(it);
          if (m.contains("result") && m["result"].contains("effective_cycle") &&
              m["result"]["effective_cycle"].is_number_unsigned()) {
            const auto cycle = m["result"]["effective_cycle"].get<std::uint64_t>();
            ++sets_acked;
            if (cycle < last_cycle) ++cycles_backwards;
            last_cycle = cycle;
          } else if (m.contains("result")) {
            ++sets_unnamed;
          } else {
            ++sets_failed;
            if (first_error.empty()) first_error = "param.set: " + m.dump();
          }
        }
        if (!open) {
          if (first_error.empty()) first_error = "the daemon closed the param.set connection";
          setter.reset();
        }
      }
    }
  }

  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::uint64_t received = 0, dropped = 0, least = UINT64_MAX;
  int streams_started = 0;
  for (const auto& c : counts) {
    received += c.received;
    dropped += c.dropped_by_daemon;
    least = std::min(least, c.received);
    streams_started += c.started ? 1 : 0;
  }
  const json summary{{"duration_s", o.duration_s},
                     {"elapsed_s", seconds},
                     {"streams", o.streams},
                     {"streams_started", streams_started},
                     {"stream_rate_hz", o.stream_rate_hz},
                     {"notifications_received", received},
                     {"notifications_received_least", o.streams > 0 ? least : 0},
                     {"notifications_dropped_by_daemon", dropped},
                     {"sets_per_second", o.sets_per_second},
                     {"sets_sent", sets_sent},
                     {"sets_acknowledged", sets_acked},
                     {"sets_without_cycle", sets_unnamed},
                     {"sets_failed", sets_failed},
                     {"sets_unanswered", outstanding.size()},
                     {"effective_cycle_went_back", cycles_backwards},
                     {"ack_ms",
                      {{"p50", percentile(ack_ms, 0.5)},
                       {"p99", percentile(ack_ms, 0.99)},
                       {"max", percentile(ack_ms, 1.0)}}},
                     {"first_error", first_error}};
  std::cout << summary.dump() << std::endl;
  const bool all_acked =
      sets_acked == sets_sent && outstanding.empty() && sets_failed == 0 && sets_unnamed == 0;
  return all_acked && streams_started == o.streams ? 0 : 1;
}
