#include "daemon/control/server.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <system_error>
#include <thread>
#include <unordered_map>

#include <grp.h>
#include <pwd.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/timerfd.h>
#include <sys/un.h>
#include <unistd.h>

#include "client/socket_path.hpp"

namespace hapticd::daemon::control {

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

std::string errno_text(int e) { return std::generic_category().message(e); }

/// The group's gid; throws ServerError if it does not exist.
gid_t lookup_group(const std::string& name) {
  std::vector<char> buf(16384);
  group gr{};
  group* result = nullptr;
  int rc = ::getgrnam_r(name.c_str(), &gr, buf.data(), buf.size(), &result);
  if (rc != 0 || result == nullptr) {
    throw ServerError("control socket group '" + name + "' does not exist" +
                      (rc != 0 ? " (getgrnam: " + errno_text(rc) + ")" : std::string()));
  }
  return gr.gr_gid;
}

/// Supplementary groups of a peer: the "Groups:" line of /proc/<pid>/status
/// when that process still has the peer's uid, else the group database.
std::vector<gid_t> peer_groups(pid_t pid, uid_t uid, gid_t gid) {
  std::vector<gid_t> groups;
  if (pid > 0) {
    std::ifstream status("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    bool uid_matches = false;
    bool have_groups = false;
    while (std::getline(status, line)) {
      std::istringstream fields(line);
      std::string key;
      fields >> key;
      if (key == "Uid:") {
        unsigned long real = 0, effective = 0;
        fields >> real >> effective;
        uid_matches = effective == uid;  // guards against a reused pid
      } else if (key == "Groups:") {
        unsigned long g = 0;
        while (fields >> g) groups.push_back(static_cast<gid_t>(g));
        have_groups = true;
      }
    }
    if (uid_matches && have_groups) return groups;
    groups.clear();
  }
  std::vector<char> buf(16384);
  passwd pw{};
  passwd* result = nullptr;
  if (::getpwuid_r(uid, &pw, buf.data(), buf.size(), &result) != 0 || result == nullptr) return groups;
  int n = 64;
  groups.resize(static_cast<std::size_t>(n));
  if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) {
    groups.resize(static_cast<std::size_t>(n));
    if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) n = 0;
  }
  groups.resize(static_cast<std::size_t>(std::max(n, 0)));
  return groups;
}

struct Method {
  Handler handler;
  Access access;
};

struct Connection {
  std::uint64_t id = 0;
  int fd = -1;
  PeerInfo peer;
  std::string in;
  std::string out;
  std::size_t out_offset = 0;  ///< bytes of `out` already sent
  Clock::time_point last_activity;
  std::uint32_t events = 0;  ///< current epoll interest
  bool paused = false;       ///< not reading: output queue above the limit
  bool closing = false;      ///< close once `out` is sent
  bool dead = false;         ///< closed at the end of this epoll batch
  // stream subscription
  int timer_fd = -1;
  std::uint64_t subscription = 0;
  std::vector<std::string> channels;
  double rate_hz = 0.0;
  std::uint64_t seq = 0;
  std::uint64_t dropped = 0;

  std::size_t pending() const noexcept { return out.size() - out_offset; }
};

}  // namespace

json to_json(const ServerStats& s) {
  return {{"connections", s.connections},
          {"refused_busy", s.refused_busy},
          {"requests", s.requests},
          {"errors", s.errors},
          {"idle_disconnects", s.idle_disconnects},
          {"slow_disconnects", s.slow_disconnects},
          {"notifications_sent", s.notifications_sent},
          {"notifications_dropped", s.notifications_dropped},
          {"clients", s.clients},
          {"subscribers", s.subscribers}};
}

struct ControlServer::Impl {
  ServerOptions opts;
  std::string path;
  std::map<std::string, Method, std::less<>> methods;
  StreamSource source;
  bool has_group = false;
  gid_t group_gid = 0;
  uid_t euid = ::geteuid();

  int listen_fd = -1;
  int epoll_fd = -1;
  int wake_fd = -1;
  ino_t socket_ino = 0;
  dev_t socket_dev = 0;
  std::thread thread;
  bool started = false;

  std::unordered_map<int, std::unique_ptr<Connection>> conns;  // by socket fd
  std::unordered_map<int, Connection*> timers;                 // by timer fd
  std::uint64_t next_client_id = 1;
  std::uint64_t next_subscription = 1;

  mutable std::mutex stats_mutex;
  ServerStats counters;

  template <typename F>
  void count(F&& update) {
    std::lock_guard lock(stats_mutex);
    update(counters);
  }

  // ---- socket setup -------------------------------------------------------
  void open_socket();
  void close_all();

  // ---- loop -----------------------------------------------------------------
  void run();
  int idle_wait_ms() const;
  void check_idle();
  void accept_clients();
  void on_socket_event(Connection& c, std::uint32_t ev);
  void on_timer(Connection& c);
  void read_input(Connection& c);
  void process_lines(Connection& c);
  void handle_line(Connection& c, std::string_view line);
  json dispatch(Connection& c, const std::string& name, const json& params);
  json stream_start(Connection& c, const json& params);
  json stream_stop(Connection& c);
  void end_stream(Connection& c);
  void send_error(Connection& c, const json& id, const RpcError& e);
  void enqueue(Connection& c, const json& message);
  void flush(Connection& c);
  void update_events(Connection& c);
  void kill(Connection& c);
  bool permitted(const PeerInfo& peer) const;
  std::string refusal(const std::string& method, const PeerInfo& peer) const;
};

// ---------------------------------------------------------------------------

void ControlServer::Impl::open_socket() {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof(addr.sun_path)) {
    throw ServerError("control socket path '" + path + "' is longer than " +
                      std::to_string(sizeof(addr.sun_path) - 1) + " bytes");
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  const auto* sa = reinterpret_cast<const sockaddr*>(&addr);

  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      throw ServerError("control socket path '" + path + "' exists and is not a socket; not removing it");
    }
    int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (probe < 0) throw ServerError("socket: " + errno_text(errno));
    int rc = ::connect(probe, sa, sizeof(addr));
    int e = errno;
    ::close(probe);
    if (rc == 0) {
      throw ServerError("another hapticd is already running on " + path +
                        " (it answered a connect); stop it first");
    }
    if (e != ECONNREFUSED) {
      throw ServerError("cannot tell whether " + path + " is in use (connect: " + errno_text(e) + ")");
    }
    if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
      throw ServerError("cannot remove stale socket " + path + ": " + errno_text(errno));
    }
  }

  listen_fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_fd < 0) throw ServerError("socket: " + errno_text(errno));
  if (::bind(listen_fd, sa, sizeof(addr)) != 0) {
    throw ServerError("cannot bind control socket " + path + ": " + errno_text(errno));
  }
  if (::lstat(path.c_str(), &st) == 0) {
    socket_ino = st.st_ino;
    socket_dev = st.st_dev;
  }
  // Mode and group before listen(): until then nobody can connect.
  if (::chmod(path.c_str(), opts.mode) != 0) {
    throw ServerError("cannot chmod control socket " + path + ": " + errno_text(errno));
  }
  if (has_group && ::chown(path.c_str(), static_cast<uid_t>(-1), group_gid) != 0) {
    throw ServerError("cannot give control socket " + path + " to group '" + opts.group +
                      "': " + errno_text(errno));
  }
  if (::listen(listen_fd, 64) != 0) throw ServerError("listen on " + path + ": " + errno_text(errno));

  epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd < 0) throw ServerError("epoll_create1: " + errno_text(errno));
  wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd < 0) throw ServerError("eventfd: " + errno_text(errno));
  for (int fd : {listen_fd, wake_fd}) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0)
      throw ServerError("epoll_ctl: " + errno_text(errno));
  }
}

void ControlServer::Impl::close_all() {
  for (auto& [fd, c] : conns) {
    if (c->timer_fd >= 0) ::close(c->timer_fd);
    ::close(fd);
  }
  conns.clear();
  timers.clear();
  if (listen_fd >= 0) {
    ::close(listen_fd);
    // Remove the socket only if it is still ours.
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0 && st.st_ino == socket_ino && st.st_dev == socket_dev) {
      ::unlink(path.c_str());
    }
  }
  for (int* fd : {&listen_fd, &epoll_fd, &wake_fd}) {
    if (*fd >= 0 && fd != &listen_fd) ::close(*fd);
    *fd = -1;
  }
  count([](ServerStats& s) {
    s.clients = 0;
    s.subscribers = 0;
  });
}

// ---------------------------------------------------------------------------

int ControlServer::Impl::idle_wait_ms() const {
  auto now = Clock::now();
  std::optional<Clock::duration> soonest;
  if (opts.idle_timeout <= Clock::duration::zero()) return -1;  // 0: never idle
  for (const auto& [fd, c] : conns) {
    if (c->dead || c->timer_fd >= 0) continue;
    auto left = c->last_activity + opts.idle_timeout - now;
    if (!soonest || left < *soonest) soonest = left;
  }
  if (!soonest) return -1;
  auto ms = std::chrono::ceil<std::chrono::milliseconds>(*soonest).count();
  return static_cast<int>(std::clamp<long long>(ms, 0, 60'000));
}

void ControlServer::Impl::check_idle() {
  if (opts.idle_timeout <= Clock::duration::zero()) return;  // 0: never idle
  auto now = Clock::now();
  for (auto& [fd, c] : conns) {
    if (c->dead || c->timer_fd >= 0) continue;
    if (now - c->last_activity >= opts.idle_timeout) {
      count([](ServerStats& s) { ++s.idle_disconnects; });
      kill(*c);
    }
  }
}

void ControlServer::Impl::run() {
  std::array<epoll_event, 64> events{};
  for (;;) {
    int n = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), idle_wait_ms());
    if (n < 0) {
      if (errno == EINTR) continue;
      std::fprintf(stderr, "hapticd: control: epoll_wait: %s; control plane stopped\n",
                   errno_text(errno).c_str());
      return;
    }
    for (int i = 0; i < n; ++i) {
      const int fd = events[static_cast<std::size_t>(i)].data.fd;
      const std::uint32_t ev = events[static_cast<std::size_t>(i)].events;
      if (fd == wake_fd) return;
      if (fd == listen_fd) {
        accept_clients();
        continue;
      }
      Connection* c = nullptr;
      bool timer = false;
      if (auto it = conns.find(fd); it != conns.end()) {
        c = it->second.get();
      } else if (auto t = timers.find(fd); t != timers.end()) {
        c = t->second;
        timer = true;
      }
      if (c == nullptr || c->dead) continue;
      try {
        if (timer) {
          on_timer(*c);
        } else {
          on_socket_event(*c, ev);
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "hapticd: control: client %llu dropped: %s\n",
                     static_cast<unsigned long long>(c->id), e.what());
        kill(*c);
      }
    }
    check_idle();
    // Close the dead only now, so no fd is reused within a batch.
    for (auto it = conns.begin(); it != conns.end();) {
      if (it->second->dead) {
        Connection& c = *it->second;
        if (c.timer_fd >= 0) {
          timers.erase(c.timer_fd);
          ::close(c.timer_fd);
        }
        ::close(c.fd);
        it = conns.erase(it);
      } else {
        ++it;
      }
    }
    std::size_t subscribers = timers.size();
    std::size_t clients = conns.size();
    count([&](ServerStats& s) {
      s.clients = clients;
      s.subscribers = subscribers;
    });
  }
}

void ControlServer::Impl::accept_clients() {
  for (;;) {
    int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        std::fprintf(stderr, "hapticd: control: accept: %s\n", errno_text(errno).c_str());
      }
      return;
    }
    count([](ServerStats& s) { ++s.connections; });
    std::size_t live = 0;
    for (const auto& [cfd, c] : conns) live += c->dead ? 0 : 1;
    if (live >= opts.max_clients) {
      RpcError busy(rpc::code::busy,
                    "too many clients: " + std::to_string(live) + " connected, the limit is " +
                        std::to_string(opts.max_clients),
                    json{{"limit", opts.max_clients}});
      std::string line = rpc::to_line(rpc::make_error(nullptr, busy));
      // Best effort: a fresh socket's buffer takes a short line.
      [[maybe_unused]] ssize_t sent = ::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      ::close(fd);
      count([](ServerStats& s) {
        ++s.refused_busy;
        ++s.errors;
      });
      continue;
    }
    auto c = std::make_unique<Connection>();
    c->id = next_client_id++;
    c->fd = fd;
    c->last_activity = Clock::now();
    ucred cred{};
    socklen_t len = sizeof(cred);
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) {
      c->peer.pid = cred.pid;
      c->peer.uid = cred.uid;
      c->peer.gid = cred.gid;
    } else {
      c->peer.uid = static_cast<uid_t>(-1);
      c->peer.gid = static_cast<gid_t>(-1);
    }
    c->peer.client_id = c->id;
    c->peer.can_write = permitted(c->peer);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0) {
      ::close(fd);
      continue;
    }
    c->events = EPOLLIN;
    conns.emplace(fd, std::move(c));
  }
}

bool ControlServer::Impl::permitted(const PeerInfo& peer) const {
  if (peer.uid == euid || peer.uid == 0) return true;
  if (!has_group) return false;
  if (peer.gid == group_gid) return true;
  auto groups = peer_groups(peer.pid, peer.uid, peer.gid);
  return std::find(groups.begin(), groups.end(), group_gid) != groups.end();
}

std::string ControlServer::Impl::refusal(const std::string& method, const PeerInfo& peer) const {
  std::string msg = "'" + method + "' changes the daemon's state: uid " + std::to_string(peer.uid) +
                    " is not the daemon's uid " + std::to_string(euid) + " nor root";
  if (has_group) {
    msg += ", and is not a member of group '" + opts.group + "' (gid " + std::to_string(group_gid) + ")";
  } else {
    msg += " (no control group is configured)";
  }
  return msg;
}

// ---------------------------------------------------------------------------

void ControlServer::Impl::on_socket_event(Connection& c, std::uint32_t ev) {
  if (ev & EPOLLOUT) flush(c);
  if (c.dead) return;
  if (ev & EPOLLIN) {
    read_input(c);
  } else if (ev & (EPOLLHUP | EPOLLERR)) {
    kill(c);  // peer gone while we were not reading
  }
}

void ControlServer::Impl::read_input(Connection& c) {
  char buf[65536];
  // A bounded number of reads per wake-up keeps one busy client from starving the rest.
  for (int round = 0; round < 8 && !c.dead && !c.closing && !c.paused; ++round) {
    ssize_t n = ::recv(c.fd, buf, sizeof(buf), 0);
    if (n > 0) {
      c.in.append(buf, static_cast<std::size_t>(n));
      c.last_activity = Clock::now();
      process_lines(c);
      continue;
    }
    if (n == 0) {
      // End of input: a last line without '\n' still counts, then close once answered.
      if (!c.in.empty() && !c.closing) {
        std::string last = std::move(c.in);
        c.in.clear();
        if (last.size() <= opts.max_message_bytes) handle_line(c, last);
      }
      c.closing = true;
      break;
    }
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) kill(c);
    break;
  }
  if (!c.dead) update_events(c);
}

void ControlServer::Impl::process_lines(Connection& c) {
  std::size_t start = 0;
  while (!c.dead && !c.closing) {
    if (c.pending() >= opts.max_output_bytes) {
      c.paused = true;
      break;
    }
    auto nl = c.in.find('\n', start);
    if (nl == std::string::npos) {
      if (c.in.size() - start > opts.max_message_bytes)
        nl = c.in.size();  // too large: handled below
      else
        break;
    }
    if (nl - start > opts.max_message_bytes) {
      send_error(c, nullptr,
                 RpcError(rpc::code::message_too_large,
                          "request line longer than " + std::to_string(opts.max_message_bytes) +
                              " bytes; closing the connection",
                          json{{"limit", opts.max_message_bytes}}));
      c.closing = true;
      c.in.clear();
      start = 0;
      break;
    }
    std::string_view line(c.in.data() + start, nl - start);
    start = nl + 1;
    handle_line(c, line);
  }
  if (start > 0) c.in.erase(0, std::min(start, c.in.size()));
}

void ControlServer::Impl::handle_line(Connection& c, std::string_view line) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
    line.remove_suffix(1);
  if (line.find_first_not_of(" \t") == std::string_view::npos) return;
  count([](ServerStats& s) { ++s.requests; });

  json request;
  try {
    request = json::parse(line);
  } catch (const json::exception& e) {
    // parse_error, and also out_of_range for numbers like 1e999: both are
    // lines that are not JSON we can represent.
    send_error(c, nullptr, RpcError(rpc::code::parse_error, std::string("parse error: ") + e.what()));
    return;
  }
  if (request.is_array()) {
    send_error(c, nullptr, RpcError(rpc::code::invalid_request, "batch requests are not supported"));
    return;
  }
  if (!request.is_object()) {
    send_error(c, nullptr, RpcError(rpc::code::invalid_request, "a request must be a JSON object"));
    return;
  }
  const bool is_notification = !request.contains("id");
  json id = is_notification ? json(nullptr) : request["id"];
  if (!id.is_null() && !id.is_string() && !id.is_number()) {
    send_error(c, nullptr, RpcError(rpc::code::invalid_request, "\"id\" must be a string, a number or null"));
    return;
  }
  auto version = request.find("jsonrpc");
  if (version == request.end() || !version->is_string() || *version != rpc::version) {
    send_error(c, id, RpcError(rpc::code::invalid_request, "\"jsonrpc\" must be \"2.0\""));
    return;
  }
  auto method = request.find("method");
  if (method == request.end() || !method->is_string()) {
    send_error(c, id, RpcError(rpc::code::invalid_request, "\"method\" must be a string"));
    return;
  }
  json params = json::object();
  if (auto p = request.find("params"); p != request.end() && !p->is_null()) {
    if (!p->is_object()) {
      send_error(c, id,
                 RpcError(rpc::code::invalid_params, "\"params\" must be an object (parameters by name)"));
      return;
    }
    params = std::move(*p);
  }

  json result;
  try {
    result = dispatch(c, method->get<std::string>(), params);
  } catch (const RpcError& e) {
    if (!is_notification) send_error(c, id, e);
    return;
  } catch (const json::exception& e) {
    if (!is_notification)
      send_error(c, id, RpcError(rpc::code::invalid_params, std::string("invalid params: ") + e.what()));
    return;
  } catch (const std::exception& e) {
    if (!is_notification) send_error(c, id, RpcError(rpc::code::internal_error, e.what()));
    return;
  }
  if (!is_notification && !c.dead) enqueue(c, rpc::make_result(id, std::move(result)));
}

json ControlServer::Impl::dispatch(Connection& c, const std::string& name, const json& params) {
  if (source && name == "stream") return stream_start(c, params);
  if (source && name == "stream.stop") return stream_stop(c);
  auto it = methods.find(name);
  if (it == methods.end()) {
    throw RpcError(rpc::code::method_not_found, "method '" + name + "' not found", json{{"method", name}});
  }
  if (it->second.access == Access::write && !c.peer.can_write) {
    throw RpcError(rpc::code::not_permitted, refusal(name, c.peer),
                   json{{"method", name},
                        {"uid", c.peer.uid},
                        {"required_group", has_group ? json(opts.group) : json(nullptr)}});
  }
  return it->second.handler(params, c.peer);
}

json ControlServer::Impl::stream_start(Connection& c, const json& params) {
  auto rate = params.find("rate_hz");
  if (rate == params.end() || !rate->is_number()) {
    throw RpcError(rpc::code::invalid_params, "stream needs \"rate_hz\" (a number of samples per second)");
  }
  double hz = rate->get<double>();
  if (!(hz > 0.0) || hz > opts.max_stream_rate_hz) {
    throw RpcError(rpc::code::invalid_params,
                   "rate_hz must be > 0 and <= " + json(opts.max_stream_rate_hz).dump(),
                   json{{"limit", opts.max_stream_rate_hz}});
  }
  std::vector<std::string> channels;
  if (auto ch = params.find("channels"); ch != params.end() && !ch->is_null()) {
    if (!ch->is_array())
      throw RpcError(rpc::code::invalid_params, "\"channels\" must be an array of strings");
    for (const auto& name : *ch) {
      if (!name.is_string())
        throw RpcError(rpc::code::invalid_params, "\"channels\" must be an array of strings");
      channels.push_back(name.get<std::string>());
    }
  }
  (void)source(channels);  // validates the channels: throws RpcError for unknown ones

  if (c.timer_fd < 0) {
    c.timer_fd = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (c.timer_fd < 0) throw RpcError(rpc::code::busy, "cannot create a stream timer: " + errno_text(errno));
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = c.timer_fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, c.timer_fd, &ev) != 0) {
      ::close(c.timer_fd);
      c.timer_fd = -1;
      throw RpcError(rpc::code::busy, "cannot watch a stream timer: " + errno_text(errno));
    }
    timers.emplace(c.timer_fd, &c);
  }
  auto period_ns = static_cast<long long>(std::llround(1e9 / hz));
  if (period_ns < 1) period_ns = 1;
  itimerspec spec{};
  spec.it_interval.tv_sec = static_cast<time_t>(period_ns / 1'000'000'000);
  spec.it_interval.tv_nsec = static_cast<long>(period_ns % 1'000'000'000);
  spec.it_value = spec.it_interval;
  ::timerfd_settime(c.timer_fd, 0, &spec, nullptr);
  c.subscription = next_subscription++;
  c.channels = channels;
  c.rate_hz = hz;
  c.seq = 0;
  c.dropped = 0;
  return {{"subscription", c.subscription}, {"rate_hz", hz}, {"channels", channels}};
}

json ControlServer::Impl::stream_stop(Connection& c) {
  if (c.timer_fd < 0) return {{"subscription", nullptr}, {"sent", 0}, {"dropped", 0}};
  json result{{"subscription", c.subscription}, {"sent", c.seq}, {"dropped", c.dropped}};
  end_stream(c);
  return result;
}

void ControlServer::Impl::end_stream(Connection& c) {
  if (c.timer_fd < 0) return;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.timer_fd, nullptr);
  timers.erase(c.timer_fd);
  ::close(c.timer_fd);
  c.timer_fd = -1;
  c.subscription = 0;
  c.last_activity = Clock::now();  // idle time counts from the end of the stream
}

void ControlServer::Impl::on_timer(Connection& c) {
  std::uint64_t expirations = 0;
  if (::read(c.timer_fd, &expirations, sizeof(expirations)) != static_cast<ssize_t>(sizeof(expirations)))
    return;
  if (expirations == 0) return;
  // Ticks this thread slept through are samples the client did not get.
  std::uint64_t lost = expirations - 1;
  if (c.pending() >= opts.max_output_bytes || c.closing) {
    lost += 1;
  } else {
    json params;
    try {
      params = source(c.channels);
    } catch (const std::exception&) {
      lost += 1;  // the source could not produce this sample
      params = nullptr;
    }
    if (!params.is_null()) {
      if (!params.is_object()) params = json{{"value", std::move(params)}};
      c.dropped += lost;
      lost = 0;
      params["seq"] = c.seq++;
      params["dropped"] = c.dropped;
      enqueue(c, rpc::make_notification(rpc::telemetry_method, std::move(params)));
      count([](ServerStats& s) { ++s.notifications_sent; });
    }
  }
  if (lost > 0) {
    c.dropped += lost;
    count([lost](ServerStats& s) { s.notifications_dropped += lost; });
  }
}

// ---------------------------------------------------------------------------

void ControlServer::Impl::send_error(Connection& c, const json& id, const RpcError& e) {
  count([](ServerStats& s) { ++s.errors; });
  enqueue(c, rpc::make_error(id, e));
}

void ControlServer::Impl::enqueue(Connection& c, const json& message) {
  if (c.dead) return;
  if (c.pending() > 4 * opts.max_output_bytes) {
    // It sends requests but never reads the answers.
    count([](ServerStats& s) { ++s.slow_disconnects; });
    kill(c);
    return;
  }
  if (c.out_offset > 0 && c.out_offset >= c.out.size() / 2) {
    c.out.erase(0, c.out_offset);
    c.out_offset = 0;
  }
  c.out += rpc::to_line(message);
  flush(c);
}

void ControlServer::Impl::flush(Connection& c) {
  while (!c.dead && c.pending() > 0) {
    ssize_t n = ::send(c.fd, c.out.data() + c.out_offset, c.pending(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      c.out_offset += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    kill(c);  // EPIPE, ECONNRESET: the peer is gone
    return;
  }
  if (c.pending() == 0) {
    c.out.clear();
    c.out_offset = 0;
  }
  if (c.paused && c.pending() < opts.max_output_bytes) {
    c.paused = false;
    process_lines(c);  // lines read before the pause
  }
  update_events(c);
}

void ControlServer::Impl::update_events(Connection& c) {
  if (c.dead) return;
  if (c.closing && c.pending() == 0) {
    kill(c);
    return;
  }
  std::uint32_t want = (c.paused || c.closing ? 0u : static_cast<std::uint32_t>(EPOLLIN)) |
                       (c.pending() > 0 ? static_cast<std::uint32_t>(EPOLLOUT) : 0u);
  if (want == c.events) return;
  epoll_event ev{};
  ev.events = want;
  ev.data.fd = c.fd;
  if (::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, c.fd, &ev) != 0) {
    kill(c);
    return;
  }
  c.events = want;
}

void ControlServer::Impl::kill(Connection& c) {
  if (c.dead) return;
  c.dead = true;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.fd, nullptr);
  if (c.timer_fd >= 0) ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.timer_fd, nullptr);
}

// ---------------------------------------------------------------------------

ControlServer::ControlServer(ServerOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->opts = std::move(options);
  impl_->path = client::resolve_socket_path(impl_->opts.socket_path);
  if (impl_->opts.max_message_bytes == 0 || impl_->opts.max_clients == 0 ||
      impl_->opts.max_output_bytes == 0) {
    throw ServerError("control server limits must be positive");
  }
}

ControlServer::~ControlServer() { stop(); }

void ControlServer::register_method(const std::string& name, Handler handler, Access access) {
  if (impl_->started) throw std::logic_error("register_method('" + name + "') after start()");
  if (!handler) throw std::logic_error("register_method('" + name + "') without a handler");
  if (name == "stream" || name == "stream.stop") throw std::logic_error("'" + name + "' is built in");
  if (!impl_->methods.emplace(name, Method{std::move(handler), access}).second) {
    throw std::logic_error("method '" + name + "' registered twice");
  }
}

void ControlServer::set_stream_source(StreamSource source) {
  if (impl_->started) throw std::logic_error("set_stream_source() after start()");
  impl_->source = std::move(source);
}

void ControlServer::start() {
  if (impl_->started) return;
  if (!impl_->opts.group.empty()) {
    impl_->group_gid = lookup_group(impl_->opts.group);
    impl_->has_group = true;
  }
  try {
    impl_->open_socket();
  } catch (...) {
    impl_->close_all();
    throw;
  }
  impl_->counters = ServerStats{};
  impl_->started = true;
  impl_->thread = std::thread([impl = impl_.get()] { impl->run(); });
}

void ControlServer::stop() {
  if (!impl_ || !impl_->started) return;
  std::uint64_t one = 1;
  [[maybe_unused]] ssize_t n = ::write(impl_->wake_fd, &one, sizeof(one));
  if (impl_->thread.joinable()) impl_->thread.join();
  impl_->close_all();
  impl_->started = false;
}

const std::string& ControlServer::socket_path() const noexcept { return impl_->path; }

ServerStats ControlServer::stats() const {
  std::lock_guard lock(impl_->stats_mutex);
  return impl_->counters;
}

}  // namespace hapticd::daemon::control
