// The control server's loop: one thread, one epoll set holding the listening
// socket, every client socket, every stream timer and a wake-up eventfd.
// The pieces it drives each have their file: listening_socket (the socket
// file), peer_credentials (who may write), connection (a client's buffers),
// stream_subscription (a client's telemetry timer), dispatcher (a request
// line to its reply).

#include "daemon/control/server.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <mutex>
#include <optional>
#include <system_error>
#include <thread>
#include <unordered_map>

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "client/socket_path.hpp"
#include "daemon/control/connection.hpp"
#include "daemon/control/dispatcher.hpp"
#include "daemon/control/listening_socket.hpp"
#include "daemon/control/peer_credentials.hpp"
#include "daemon/system/thread_placement.hpp"
#include "world/text.hpp"

namespace hapticd::daemon::control {

namespace {
using Clock = std::chrono::steady_clock;
using nlohmann::json;

using world::text::errno_text;

/// 6 significant digits, no trailing zeros: 0.1, 1000, 1e-300.
std::string number_text(double value) {
  return world::text::format_significant(value, world::text::precision::message);
}
}  // namespace

json to_json(const ServerStats& s) {
  return {{"connections", s.connections},
          {"refused_busy", s.refused_busy},
          {"requests", s.requests},
          {"errors", s.errors},
          {"idle_disconnects", s.idle_disconnects},
          {"slow_disconnects", s.slow_disconnects},
          {"evictions", s.evictions},
          {"over_limit_served", s.over_limit_served},
          {"notifications_sent", s.notifications_sent},
          {"notifications_dropped", s.notifications_dropped},
          {"clients", s.clients},
          {"subscribers", s.subscribers}};
}

struct ControlServer::Impl {
  ServerOptions opts;
  std::string path;
  Dispatcher dispatcher;
  /// `"name"` of each Precedence::first method, as it appears in a request line.
  std::vector<std::string> first_method_needles;
  /// What a connection over max_clients may call: the Precedence::first
  /// methods and ServerOptions::over_limit_methods.
  std::vector<std::string> over_limit_names;
  StreamSource source;
  std::optional<WriteAccess> access;  // from start()

  ListeningSocket listener;
  int epoll_fd = -1;
  int wake_fd = -1;
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

  void open();
  void close_all();

  void run();
  bool servable(Connection& c) const;
  bool any_servable() const;
  void serve_turn();
  template <typename Work>
  void for_client(Connection& c, Work&& work);
  void serve_one(Connection& c);
  bool calls_first_method(std::string_view line) const;
  int idle_wait_ms() const;
  void check_idle();
  void reap_dead();
  void accept_clients();
  std::size_t live_clients() const;
  bool evict_for_writer();
  std::size_t line_limit(const Connection& c) const;
  bool admitted_over_limit(const std::string& method) const;
  void make_room_over_limit();
  void refuse_over_limit(Connection& c, const json& id, const std::string& why);
  void on_socket_event(Connection& c, std::uint32_t ev);
  void on_timer(Connection& c);
  void count_dropped(Connection& c, std::uint64_t samples);
  void read_input(Connection& c);
  bool handle_line(Connection& c, std::string_view line);
  std::optional<json> built_in(Connection& c, const std::string& name, const json& params);
  json stream_start(Connection& c, const json& params);
  json stream_stop(Connection& c);
  void end_stream(Connection& c);
  void send_error(Connection& c, const json& id, const RpcError& e);
  void enqueue(Connection& c, const json& message);
  void flush(Connection& c);
  void update_events(Connection& c);
  void kill(Connection& c);
};

// ---- start and stop ----------------------------------------------------------

void ControlServer::Impl::open() {
  access.emplace(opts.group);
  listener.open(path, opts.mode,
                access->has_group() ? std::optional<gid_t>(access->group_gid()) : std::nullopt, opts.group);
  epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd < 0) throw ServerError("epoll_create1: " + errno_text(errno));
  wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd < 0) throw ServerError("eventfd: " + errno_text(errno));
  for (int fd : {listener.fd(), wake_fd}) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0)
      throw ServerError("epoll_ctl: " + errno_text(errno));
  }
}

void ControlServer::Impl::close_all() {
  conns.clear();  // closes their sockets and timers
  timers.clear();
  listener.close();
  for (int* fd : {&epoll_fd, &wake_fd}) {
    if (*fd >= 0) ::close(*fd);
    *fd = -1;
  }
  count([](ServerStats& s) {
    s.clients = 0;
    s.subscribers = 0;
  });
}

// ---- the loop -----------------------------------------------------------------

// When the next connection falls idle, or an over-limit one's wait ends.
int ControlServer::Impl::idle_wait_ms() const {
  const auto now = Clock::now();
  const bool idles = opts.idle_timeout > Clock::duration::zero();  // 0: never idle
  std::optional<Clock::duration> soonest;
  for (const auto& [fd, c] : conns) {
    if (c->dead) continue;
    std::optional<Clock::time_point> due;
    if (c->over_limit) {
      due = c->deadline;
    } else if (idles && !c->stream.active()) {
      due = c->last_activity + opts.idle_timeout;
    }
    if (!due) continue;
    if (const auto left = *due - now; !soonest || left < *soonest) soonest = left;
  }
  if (!soonest) return -1;
  auto ms = std::chrono::ceil<std::chrono::milliseconds>(*soonest).count();
  return static_cast<int>(std::clamp<long long>(ms, 0, 60'000));
}

void ControlServer::Impl::check_idle() {
  const auto now = Clock::now();
  const bool idles = opts.idle_timeout > Clock::duration::zero();  // 0: never idle
  for (auto& [fd, c] : conns) {
    if (c->dead) continue;
    if (c->over_limit) {
      if (now < c->deadline) continue;
      if (!c->closing) {
        refuse_over_limit(
            *c, nullptr,
            "no complete request within " + std::to_string(opts.over_limit_wait.count()) + " ms");
      }
      kill(*c);  // its wait is over, answered or not
      continue;
    }
    if (!idles || c->stream.active()) continue;
    if (now - c->last_activity >= opts.idle_timeout) {
      count([](ServerStats& s) { ++s.idle_disconnects; });
      kill(*c);
    }
  }
}

// One turn: wait for events (not at all while requests are queued), read
// what arrived, then serve_turn(). A turn is bounded: at most
// requests_per_turn requests per client, so an estop that arrives during it
// is served first in the next one.
void ControlServer::Impl::run() {
  std::array<epoll_event, 64> events{};
  for (;;) {
    const int wait_ms = any_servable() ? 0 : idle_wait_ms();
    int n = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), wait_ms);
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
      if (fd == listener.fd()) {
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
      for_client(*c, [&] { timer ? on_timer(*c) : on_socket_event(*c, ev); });
    }
    serve_turn();
    check_idle();
    reap_dead();
  }
}

bool ControlServer::Impl::servable(Connection& c) const {
  return !c.dead && !c.closing && c.pending() < opts.max_output_bytes && c.has_request(line_limit(c));
}

bool ControlServer::Impl::any_servable() const {
  return std::any_of(conns.begin(), conns.end(),
                     [this](const auto& entry) { return servable(*entry.second); });
}

void ControlServer::Impl::serve_turn() {
  // First, every client whose next request is an estop (Precedence::first).
  // Only the *next* one: a client's requests keep their order, so a
  // fault.clear it sent before its estop cannot clear that estop.
  for (auto& entry : conns) {
    Connection& c = *entry.second;
    if (servable(c) && calls_first_method(c.peek_line())) for_client(c, [&] { serve_one(c); });
  }
  // Then each client in turn, a few requests each. The rest of a pipelined
  // burst waits for the next turn, unread beyond what is buffered (the
  // client's writes block), instead of holding every other client up.
  for (auto& entry : conns) {
    Connection& c = *entry.second;
    for_client(c, [&] {
      for (std::size_t i = 0; i < opts.requests_per_turn && servable(c); ++i) serve_one(c);
      update_events(c);
    });
  }
}

template <typename Work>
void ControlServer::Impl::for_client(Connection& c, Work&& work) {
  try {
    work();
  } catch (const std::exception& e) {
    // Whatever escaped the handlers (e.g. bad_alloc) ends this client only.
    std::fprintf(stderr, "hapticd: control: client %llu dropped: %s\n",
                 static_cast<unsigned long long>(c.id()), e.what());
    kill(c);
  }
}

bool ControlServer::Impl::calls_first_method(std::string_view line) const {
  // A look for the quoted name, not a parse: a false match only serves
  // that client's next request (whatever it is) a little early.
  return std::any_of(
      first_method_needles.begin(), first_method_needles.end(),
      [line](const std::string& needle) { return line.find(needle) != std::string_view::npos; });
}

void ControlServer::Impl::serve_one(Connection& c) {
  const auto line = c.next_line(line_limit(c));
  if (line.kind == Connection::Line::Kind::incomplete) return;
  if (line.kind == Connection::Line::Kind::too_large && c.over_limit) {
    refuse_over_limit(c, nullptr,
                      "its first request is longer than " + std::to_string(opts.over_limit_bytes) + " bytes");
    return;
  }
  if (line.kind == Connection::Line::Kind::too_large) {
    send_error(c, nullptr,
               RpcError(rpc::code::message_too_large,
                        "request line longer than " + std::to_string(opts.max_message_bytes) +
                            " bytes; closing the connection",
                        json{{"limit", opts.max_message_bytes}}));
    c.closing = true;
    c.discard_input();
    update_events(c);
    return;
  }
  if (handle_line(c, line.text) && c.over_limit) {
    // Over the limit: one request, then the connection closes.
    c.closing = true;
    c.discard_input();
    update_events(c);
  }
}

void ControlServer::Impl::reap_dead() {
  // Close the dead only now, so no fd is reused within a batch.
  for (auto it = conns.begin(); it != conns.end();) {
    if (it->second->dead) {
      if (it->second->stream.active()) timers.erase(it->second->stream.timer_fd());
      it = conns.erase(it);
    } else {
      ++it;
    }
  }
  std::size_t subscribers = timers.size();
  std::size_t clients = live_clients();
  count([&](ServerStats& s) {
    s.clients = clients;
    s.subscribers = subscribers;
  });
}

// ---- connections ----------------------------------------------------------------

// A bounded number per turn: the rest stay in the listen backlog (epoll
// reports it again), so a connect flood cannot keep the loop from serving.
void ControlServer::Impl::accept_clients() {
  for (std::size_t n = 0; n < opts.accepts_per_turn; ++n) {
    const int fd = listener.accept_one();
    if (fd < 0) return;
    count([](ServerStats& s) { ++s.connections; });
    PeerInfo peer = read_peer_credentials(fd);
    peer.can_write = access->permits(peer);
    const bool over = live_clients() >= opts.max_clients && !(peer.can_write && evict_for_writer());
    if (over) make_room_over_limit();
    peer.client_id = next_client_id++;
    auto owned = std::make_unique<Connection>(fd, peer);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0) continue;  // ~Connection closes fd
    Connection& c = *owned;
    c.events = EPOLLIN;
    conns.emplace(fd, std::move(owned));
    if (over) {
      c.over_limit = true;
      c.deadline = Clock::now() + opts.over_limit_wait;
      read_input(c);  // a request sent with the connect is there already: served this turn
    }
  }
}

std::size_t ControlServer::Impl::live_clients() const {
  return static_cast<std::size_t>(std::count_if(conns.begin(), conns.end(), [](const auto& entry) {
    return !entry.second->dead && !entry.second->over_limit;
  }));
}

std::size_t ControlServer::Impl::line_limit(const Connection& c) const {
  return c.over_limit ? opts.over_limit_bytes : opts.max_message_bytes;
}

bool ControlServer::Impl::admitted_over_limit(const std::string& method) const {
  return std::find(over_limit_names.begin(), over_limit_names.end(), method) != over_limit_names.end();
}

// A connect flood must not take every place over the limit from an estop:
// the oldest waiting connection gives way, after one last look at its input.
void ControlServer::Impl::make_room_over_limit() {
  Connection* oldest = nullptr;
  std::size_t waiting = 0;
  for (auto& [fd, c] : conns) {
    if (c->dead || !c->over_limit || c->closing) continue;
    ++waiting;
    if (oldest == nullptr || c->deadline < oldest->deadline) oldest = c.get();
  }
  if (oldest == nullptr || waiting < opts.max_over_limit) return;
  read_input(*oldest);
  if (servable(*oldest)) for_client(*oldest, [&] { serve_one(*oldest); });
  if (!oldest->dead && !oldest->closing) {
    refuse_over_limit(*oldest, nullptr,
                      "more than " + std::to_string(opts.max_over_limit) +
                          " connections over the limit waited for their first request; the oldest gives way");
  }
}

void ControlServer::Impl::refuse_over_limit(Connection& c, const json& id, const std::string& why) {
  std::string methods;
  for (const auto& name : over_limit_names) methods += (methods.empty() ? "" : ", ") + name;
  send_error(c, id,
             RpcError(rpc::code::busy,
                      "too many clients: " + std::to_string(live_clients()) + " connected, the limit is " +
                          std::to_string(opts.max_clients) + "; over the limit only " + methods +
                          " are served, as the first request (" + why + ")",
                      json{{"limit", opts.max_clients}}));
  count([](ServerStats& s) { ++s.refused_busy; });
  c.closing = true;
  c.discard_input();
  update_events(c);
}

// Readers filling every slot must not keep a writer (root's estop, the
// operator's fault.clear) out: the read-only connection idle the longest
// makes room, one with an active stream only if there is no other.
bool ControlServer::Impl::evict_for_writer() {
  Connection* victim = nullptr;
  auto rank = [](const Connection& c) { return std::pair(c.stream.active(), c.last_activity); };
  for (auto& [fd, c] : conns) {
    if (c->dead || c->over_limit || c->peer().can_write) continue;
    if (victim == nullptr || rank(*c) < rank(*victim)) victim = c.get();
  }
  if (victim == nullptr) return false;
  send_error(*victim, nullptr,
             RpcError(rpc::code::busy,
                      "connection closed to make room for a client with write access: all " +
                          std::to_string(opts.max_clients) +
                          " slots were taken; read-only clients give way, the longest idle first",
                      json{{"limit", opts.max_clients}}));
  kill(*victim);
  count([](ServerStats& s) { ++s.evictions; });
  return true;
}

void ControlServer::Impl::on_socket_event(Connection& c, std::uint32_t ev) {
  if (ev & EPOLLOUT) flush(c);
  if (c.dead) return;
  if (ev & EPOLLIN) {
    read_input(c);
  } else if ((ev & (EPOLLHUP | EPOLLERR)) && !servable(c)) {
    // Peer gone while we were not reading. Requests it queued before it hung
    // up are still served (a notification such as estop still acts).
    kill(c);
  }
}

void ControlServer::Impl::read_input(Connection& c) {
  // Reads only while no request is waiting: the next ones stay in the
  // kernel until serve_turn() has handled the queued ones.
  for (int round = 0; round < 8 && !c.dead && !c.closing && !c.has_request(line_limit(c)); ++round) {
    const auto received = c.receive();
    if (received == Connection::Received::data) {
      c.last_activity = Clock::now();
      continue;
    }
    if (received == Connection::Received::end_of_input) {
      // End of input: a last line without '\n' still counts, then close once answered.
      std::string last = c.take_unterminated();
      if (!last.empty() && last.size() <= line_limit(c)) handle_line(c, last);
      c.closing = true;
      break;
    }
    if (received == Connection::Received::failed) kill(c);
    break;
  }
  if (!c.dead) update_events(c);
}

// False for a blank line (nothing handled). Over the limit, a method not
// admitted there is answered -32002 (also when sent as a notification:
// the connection closes, and the client is told why).
bool ControlServer::Impl::handle_line(Connection& c, std::string_view line) {
  line = trim_request_line(line);
  if (line.empty()) return false;
  count([](ServerStats& s) { ++s.requests; });
  std::optional<std::string> refused;  // the method, when not admitted over the limit
  auto reply = dispatcher.handle(line, c.peer(), *access,
                                 [this, &c, &refused](const std::string& name, const json& params) {
                                   if (c.over_limit && !admitted_over_limit(name)) {
                                     refused = name;
                                     throw RpcError(rpc::code::busy, "over the limit");  // replaced below
                                   }
                                   return built_in(c, name, params);
                                 });
  if (refused) {
    refuse_over_limit(c, reply ? reply->message["id"] : json(nullptr),
                      "'" + *refused + "' is not one of them");
    return true;
  }
  if (c.over_limit && (!reply || !reply->is_error)) count([](ServerStats& s) { ++s.over_limit_served; });
  if (!reply) return true;
  if (reply->is_error) count([](ServerStats& s) { ++s.errors; });
  enqueue(c, reply->message);
  return true;
}

// ---- streams ----------------------------------------------------------------------

std::optional<json> ControlServer::Impl::built_in(Connection& c, const std::string& name,
                                                  const json& params) {
  if (source && name == "stream") return stream_start(c, params);
  if (source && name == "stream.stop") {
    rpc::check_params("stream.stop", params, {});
    return stream_stop(c);
  }
  return std::nullopt;
}

json ControlServer::Impl::stream_start(Connection& c, const json& params) {
  // Their types are checked below, with stream's own words.
  rpc::check_params("stream", params, {{"rate_hz", rpc::ParamType::any}, {"channels", rpc::ParamType::any}});
  auto rate = params.find("rate_hz");
  if (rate == params.end() || !rate->is_number()) {
    throw RpcError(rpc::code::invalid_params, "stream needs \"rate_hz\" (a number of samples per second)");
  }
  const double hz = rate->get<double>();
  if (!(hz >= opts.min_stream_rate_hz && hz <= opts.max_stream_rate_hz)) {
    throw RpcError(rpc::code::invalid_params,
                   "rate_hz must be from " + number_text(opts.min_stream_rate_hz) + " to " +
                       number_text(opts.max_stream_rate_hz) + " samples per second; " + number_text(hz) +
                       " is not",
                   json{{"minimum", opts.min_stream_rate_hz}, {"maximum", opts.max_stream_rate_hz}});
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

  if (c.stream.start(next_subscription, hz, channels)) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = c.stream.timer_fd();
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, c.stream.timer_fd(), &ev) != 0) {
      c.stream.stop();
      throw RpcError(rpc::code::busy, "cannot watch a stream timer: " + errno_text(errno));
    }
    timers.emplace(c.stream.timer_fd(), &c);
  }
  ++next_subscription;
  return {{"subscription", c.stream.number()}, {"rate_hz", hz}, {"channels", channels}};
}

json ControlServer::Impl::stream_stop(Connection& c) {
  if (!c.stream.active()) return {{"subscription", nullptr}, {"sent", 0}, {"dropped", 0}};
  json result{{"subscription", c.stream.number()}, {"sent", c.stream.seq}, {"dropped", c.stream.dropped}};
  end_stream(c);
  return result;
}

void ControlServer::Impl::end_stream(Connection& c) {
  if (!c.stream.active()) return;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.stream.timer_fd(), nullptr);
  timers.erase(c.stream.timer_fd());
  c.stream.stop();
  c.last_activity = Clock::now();  // idle time counts from the end of the stream
}

void ControlServer::Impl::on_timer(Connection& c) {
  const std::uint64_t expirations = c.stream.take_expirations();
  if (expirations == 0) return;
  // Ticks this thread slept through are samples the client did not get.
  count_dropped(c, expirations - 1);
  if (c.pending() >= opts.max_output_bytes || c.closing) {
    count_dropped(c, 1);  // the client does not read: no sample queued above the limit
    return;
  }
  json params;
  try {
    params = source(c.stream.channels());
  } catch (const std::exception&) {
    count_dropped(c, 1);  // the source could not produce this sample
    return;
  }
  if (params.is_null()) return;
  if (!params.is_object()) params = json{{"value", std::move(params)}};
  params["seq"] = c.stream.seq++;
  params["dropped"] = c.stream.dropped;
  enqueue(c, rpc::make_notification(rpc::telemetry_method, std::move(params)));
  count([](ServerStats& s) { ++s.notifications_sent; });
}

// The one place a lost sample is counted: the subscription's `dropped`
// (telemetry, stream.stop) and the server's notifications_dropped (stats)
// cannot disagree.
void ControlServer::Impl::count_dropped(Connection& c, std::uint64_t samples) {
  if (samples == 0) return;
  c.stream.dropped += samples;
  count([samples](ServerStats& s) { s.notifications_dropped += samples; });
}

// ---- output -----------------------------------------------------------------------

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
  c.queue(rpc::to_line(message));
  flush(c);
}

void ControlServer::Impl::flush(Connection& c) {
  if (c.dead) return;
  if (c.send_queued() == Connection::Sent::peer_gone) {
    kill(c);
    return;
  }
  update_events(c);
}

void ControlServer::Impl::update_events(Connection& c) {
  if (c.dead) return;
  if (c.closing && c.pending() == 0) {
    kill(c);
    return;
  }
  // Not reading while a request waits (serve_turn() takes it) or while the
  // output queue is above the limit (the client does not read its replies).
  const bool reading = !c.closing && c.pending() < opts.max_output_bytes && !c.has_request(line_limit(c));
  std::uint32_t want = (reading ? static_cast<std::uint32_t>(EPOLLIN) : 0u) |
                       (c.pending() > 0 ? static_cast<std::uint32_t>(EPOLLOUT) : 0u);
  if (want == c.events) return;
  epoll_event ev{};
  ev.events = want;
  ev.data.fd = c.fd();
  if (::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, c.fd(), &ev) != 0) {
    kill(c);
    return;
  }
  c.events = want;
}

void ControlServer::Impl::kill(Connection& c) {
  if (c.dead) return;
  c.dead = true;
  ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.fd(), nullptr);
  if (c.stream.active()) ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, c.stream.timer_fd(), nullptr);
}

// ---- the public face ------------------------------------------------------------------

ControlServer::ControlServer(ServerOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->opts = std::move(options);
  impl_->path = client::resolve_socket_path(impl_->opts.socket_path);
  const auto& o = impl_->opts;
  if (o.max_message_bytes == 0 || o.max_clients == 0 || o.max_output_bytes == 0 || o.requests_per_turn == 0 ||
      o.over_limit_bytes == 0 || o.max_over_limit == 0 || o.accepts_per_turn == 0 ||
      o.over_limit_wait <= std::chrono::milliseconds::zero()) {
    throw ServerError("control server limits must be positive");
  }
  impl_->over_limit_names = o.over_limit_methods;
  // What StreamSubscription can turn into a timer period.
  if (!(o.min_stream_rate_hz >= 1e-3 && o.min_stream_rate_hz <= o.max_stream_rate_hz &&
        o.max_stream_rate_hz <= 1e6)) {
    throw ServerError("control server stream rates must satisfy 0.001 <= minimum <= maximum <= 1e6 Hz");
  }
}

ControlServer::~ControlServer() { stop(); }

void ControlServer::register_method(const std::string& name, rpc::ParamMembers members, Handler handler,
                                    Access access, Precedence precedence) {
  if (impl_->started) throw std::logic_error("register_method('" + name + "') after start()");
  if (name == "stream" || name == "stream.stop") throw std::logic_error("'" + name + "' is built in");
  const bool first = precedence == Precedence::first;
  impl_->dispatcher.add(name, std::move(handler), access, std::move(members), first);
  if (first) {
    impl_->first_method_needles.push_back(json(name).dump());
    impl_->over_limit_names.insert(impl_->over_limit_names.begin(), name);
  }
}

std::vector<std::string> ControlServer::method_names() const { return impl_->dispatcher.names(); }

void ControlServer::set_stream_source(StreamSource source) {
  if (impl_->started) throw std::logic_error("set_stream_source() after start()");
  impl_->source = std::move(source);
}

void ControlServer::start() {
  if (impl_->started) return;
  try {
    impl_->open();
  } catch (...) {
    impl_->close_all();
    throw;
  }
  impl_->counters = ServerStats{};
  impl_->started = true;
  impl_->thread = std::thread([impl = impl_.get()] {
    hapticd::daemon::system::name_this_thread("hapticd-ctl");
    impl->run();
  });
  const auto problem = hapticd::daemon::system::pin_thread(impl_->thread.native_handle(), impl_->opts.cpus);
  if (!problem.empty())
    std::fprintf(stderr, "hapticd: control thread: %s; it runs on any CPU\n", problem.c_str());
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
