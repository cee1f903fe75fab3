#pragma once
/// \file
/// The control plane's server: a non-RT thread running an epoll loop on a
/// Unix stream socket, speaking newline-delimited JSON-RPC 2.0
/// (docs/protocol.md). Handlers run on that thread, one request at a time.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/types.h>

#include <nlohmann/json.hpp>

#include "rpc/jsonrpc.hpp"
#include "rpc/params.hpp"

namespace hapticd::daemon::control {

using rpc::RpcError;

/// The server could not start (socket in use by a live daemon, unknown
/// group, bind/chmod/chown failure, ...). The message says what and where.
class ServerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ServerOptions {
  /// Socket path; empty: client::resolve_socket_path() (systemd/XDG/tmp).
  std::string socket_path;
  /// Permission bits of the socket file. Connecting needs write permission.
  mode_t mode = 0660;
  /// Group owning the socket and allowed to call write methods; empty: the
  /// daemon's own group for ownership and only its uid (or root) for writes.
  std::string group;
  /// A request line longer than this gets -32003 and the connection closes.
  std::size_t max_message_bytes = std::size_t{64} * 1024;
  /// Connections holding a slot. A further one from a peer with write access
  /// takes the slot of the read-only connection idle the longest (which gets
  /// a -32002 line), so readers cannot lock the writers (and their
  /// fault.clear) out. Any other is "over the limit" (below).
  std::size_t max_clients = 16;
  /// A connection over the limit is served its first request only if that
  /// calls a Precedence::first method (estop) or one of over_limit_methods,
  /// then closed; any other request gets -32002. It must send that request
  /// within over_limit_wait of connecting and in at most over_limit_bytes,
  /// else it gets -32002 and is closed: a silent one holds nothing for long.
  std::vector<std::string> over_limit_methods = {"status"};
  std::chrono::milliseconds over_limit_wait = std::chrono::seconds(1);
  std::size_t over_limit_bytes = 4096;
  /// Connections over the limit waiting for their first request at once.
  /// One more pushes the oldest out, after one last look at its input (a
  /// client that sends its request with its connect, as hapticctl does, is
  /// still served).
  std::size_t max_over_limit = 64;
  /// Connections accepted per loop turn, so a connect flood cannot hold up
  /// the requests (an estop) already read.
  std::size_t accepts_per_turn = 32;
  /// Requests served per client per loop turn; the rest wait for the next
  /// turn, so a client pipelining thousands cannot hold the others up.
  std::size_t requests_per_turn = 8;
  /// Clients silent for this long are disconnected, unless subscribed to a stream.
  std::chrono::milliseconds idle_timeout = std::chrono::seconds(300);  ///< 0: never disconnect an idle client
  /// Queued output per client: above it, stream notifications are dropped
  /// (and counted) and requests are no longer read until it drains; a client
  /// whose queue reaches four times this (replies it never reads) is disconnected.
  std::size_t max_output_bytes = std::size_t{1024} * 1024;
  /// Stream rates a client may ask for; outside: -32602 naming the range.
  /// The lower bound keeps the timer period (1 / rate) a sane number: below
  /// ~1.1e-10 Hz it no longer fits the timer and became a 1 ns timer.
  double min_stream_rate_hz = 0.1;
  double max_stream_rate_hz = 1000.0;
  /// CPUs the server thread may run on (empty: any), e.g. away from the RT
  /// loop's ([control] cpu). A CPU that cannot be had is reported on stderr
  /// and the thread runs unpinned.
  std::vector<int> cpus;
};

/// Who is calling, from SO_PEERCRED at accept time.
struct PeerInfo {
  std::uint64_t client_id = 0;  ///< unique per connection while the server runs
  pid_t pid = 0;
  uid_t uid = 0;
  gid_t gid = 0;
  bool can_write = false;  ///< allowed to call Access::write methods
};

/// read: any peer that can connect (the socket mode is the gate).
/// write: the daemon's uid, root, or a member of ServerOptions::group.
enum class Access { read, write };

/// normal: served in turn with the client's other requests.
/// first: each loop turn, a client whose next request calls this method is
/// served before any other client's queued requests (estop).
enum class Precedence { normal, first };

/// A method handler. params is always an object ({} when absent). Throw
/// RpcError to answer with an error; a nlohmann::json exception (e.g.
/// params.at("k").get<double>() on a missing or wrong-typed member) becomes
/// -32602 invalid params; any other exception -32603 with its what().
using Handler = std::function<nlohmann::json(const nlohmann::json& params, const PeerInfo& peer)>;

/// Produces one telemetry sample for a subscriber: the object returned
/// becomes the "params" of a "telemetry" notification, to which the server
/// adds "seq" (per subscription, from 0) and "dropped" (samples this client
/// has lost so far because it did not read). channels is what the client
/// asked for (empty: the source's default set). Called on the server thread
/// at each subscriber's rate, and once when the subscription is made: an
/// RpcError thrown then (e.g. unknown channel) is the reply to `stream`.
using StreamSource = std::function<nlohmann::json(const std::vector<std::string>& channels)>;

/// Counters since start(), for `stats`.
struct ServerStats {
  std::uint64_t connections = 0;   ///< accepted (including refused as busy)
  std::uint64_t refused_busy = 0;  ///< closed at once: too many clients
  std::uint64_t requests = 0;      ///< request lines handled
  std::uint64_t errors = 0;        ///< error replies sent
  std::uint64_t idle_disconnects = 0;
  std::uint64_t slow_disconnects = 0;  ///< output queue overflow
  std::uint64_t evictions = 0;         ///< read-only clients closed to let a writer in
  std::uint64_t over_limit_served =
      0;  ///< first requests served to connections over max_clients (estop, status)
  std::uint64_t notifications_sent = 0;
  std::uint64_t notifications_dropped = 0;
  std::size_t clients = 0;      ///< connected now, holding a slot (not over the limit)
  std::size_t subscribers = 0;  ///< with an active stream now
};
nlohmann::json to_json(const ServerStats& stats);

class ControlServer {
 public:
  explicit ControlServer(ServerOptions options);
  ~ControlServer();  ///< stop()s if running
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  /// Adds a method whose params may hold `members` (each of its type; any
  /// other member, or one of the wrong type, is -32602 naming it, before the
  /// handler runs; a Precedence::first method runs first and is refused
  /// after, saying it took effect). Call before start(). Names "stream" and
  /// "stream.stop" are built in (see set_stream_source). Throws
  /// std::logic_error on a duplicate name or after start().
  void register_method(const std::string& name, rpc::ParamMembers members, Handler handler, Access access,
                       Precedence precedence = Precedence::normal);
  /// A method that takes no params members.
  void register_method(const std::string& name, Handler handler, Access access,
                       Precedence precedence = Precedence::normal) {
    register_method(name, {}, std::move(handler), access, precedence);
  }
  /// The registered methods (without the built-in stream, stream.stop), sorted.
  std::vector<std::string> method_names() const;

  /// Enables `stream` / `stream.stop` (read access). Call before start().
  void set_stream_source(StreamSource source);

  /// Creates the socket (replacing a stale one, refusing if a daemon answers
  /// on it), sets its mode and group, and starts the server thread.
  /// Throws ServerError.
  void start();
  /// Closes every connection, removes the socket and joins the thread.
  /// Idempotent. Call from the thread that called start().
  void stop();

  /// The socket path in use (resolved at construction).
  const std::string& socket_path() const noexcept;
  /// A consistent copy of the counters (thread-safe). Handlers running on
  /// the server thread may call it too.
  ServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hapticd::daemon::control
