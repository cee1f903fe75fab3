#include "client/client.hpp"
#include "world/text.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

namespace hapticd::client {

namespace {
using Clock = std::chrono::steady_clock;

int remaining_ms(Clock::time_point deadline) {
  auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  if (left <= 0) return 0;
  return left > 60'000 ? 60'000 : static_cast<int>(left);
}

using world::text::errno_text;

/// Turns a JSON-RPC error object into the exception the caller sees.
[[noreturn]] void throw_error_object(const nlohmann::json& err) {
  if (!err.is_object() || !err.contains("code") || !err["code"].is_number_integer()) {
    throw ProtocolError("hapticd sent a malformed error object: " + err.dump().substr(0, 200));
  }
  int c = err["code"].get<int>();
  std::string message = err.contains("message") && err["message"].is_string()
                            ? err["message"].get<std::string>()
                            : std::string(rpc::code_name(c));
  throw RpcError(c, message, err.contains("data") ? err["data"] : nlohmann::json());
}

/// connect() within `timeout`: 0 or the errno. Blocking, with the timeout
/// as SO_SNDTIMEO: while the daemon's listen backlog is full (a connect
/// flood) the kernel queues a blocking connect() until there is room or the
/// timeout; a non-blocking one fails with EAGAIN and is not queued (poll()
/// would then report the unconnected socket writable, and the first send()
/// fail with ENOTCONN). Then the socket is made non-blocking.
int connect_within(int fd, const sockaddr_un& addr, std::chrono::milliseconds timeout) {
  // At least 1 us: an SO_SNDTIMEO of 0 waits forever.
  const auto us =
      std::max<long long>(1, std::chrono::duration_cast<std::chrono::microseconds>(timeout).count());
  timeval wait{static_cast<time_t>(us / 1'000'000), static_cast<suseconds_t>(us % 1'000'000)};
  if (::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &wait, sizeof(wait)) != 0) return errno;
  int e = 0;
  while (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    e = errno;
    if (e != EINTR) break;
    e = 0;
  }
  if (e == EAGAIN || e == EINPROGRESS) return ETIMEDOUT;  // no room in the backlog within the timeout
  if (e != 0) return e;
  const timeval none{};
  const int flags = ::fcntl(fd, F_GETFL);
  if (::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &none, sizeof(none)) != 0 || flags < 0 ||
      ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0)
    return errno;
  return 0;
}
}  // namespace

Client Client::connect(const std::string& path, std::chrono::milliseconds timeout) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
    throw ConnectError("cannot connect to hapticd at '" + path + "': socket path is empty or longer than " +
                           std::to_string(sizeof(addr.sun_path) - 1) + " bytes",
                       path, ENAMETOOLONG);
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    int e = errno;
    throw ConnectError("socket: " + errno_text(e), path, e);
  }
  if (const int e = connect_within(fd, addr, timeout); e != 0) {
    ::close(fd);
    if (e == EACCES || e == EPERM) {
      throw ConnectError("not allowed to connect to hapticd at " + path + " (connect: " + errno_text(e) +
                             "); ask to be added to the daemon's group",
                         path, e);
    }
    if (e == ETIMEDOUT) {
      throw ConnectError(
          "hapticd at " + path + " did not accept the connection in time (its listen backlog is full)", path,
          e);
    }
    throw ConnectError("hapticd is not running at " + path + " (connect: " + errno_text(e) + ")", path, e);
  }
  return Client(fd, path, timeout);
}

Client::Client(int fd, std::string path, std::chrono::milliseconds timeout)
    : fd_(fd), path_(std::move(path)), timeout_(timeout) {}

Client::Client(Client&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      path_(std::move(other.path_)),
      timeout_(other.timeout_),
      next_id_(other.next_id_),
      inbuf_(std::move(other.inbuf_)),
      notifications_(std::move(other.notifications_)) {}

Client& Client::operator=(Client&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
    timeout_ = other.timeout_;
    next_id_ = other.next_id_;
    inbuf_ = std::move(other.inbuf_);
    notifications_ = std::move(other.notifications_);
  }
  return *this;
}

Client::~Client() {
  if (fd_ >= 0) ::close(fd_);
}

void Client::lost(const std::string& what, int error_number) {
  throw ConnectError("connection to hapticd at " + path_ + " lost: " + what, path_, error_number);
}

void Client::send_line(const std::string& line) {
  auto deadline = Clock::now() + timeout_;
  std::size_t sent = 0;
  while (sent < line.size()) {
    ssize_t n = ::send(fd_, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      pollfd p{fd_, POLLOUT, 0};
      int r = ::poll(&p, 1, remaining_ms(deadline));
      if (r == 0)
        throw ConnectError("hapticd at " + path_ + " did not accept the request in time", path_, ETIMEDOUT);
      continue;
    }
    int e = errno;
    // The daemon may have answered (e.g. busy) before closing: report that.
    try {
      if (auto msg = next_message(Clock::now() + std::chrono::milliseconds(100));
          msg && msg->contains("error")) {
        throw_error_object((*msg)["error"]);
      }
    } catch (const ConnectError&) {
      // nothing was left to read: report the send failure below
    }
    lost("send: " + errno_text(e), e);
  }
}

std::optional<nlohmann::json> Client::next_message(Clock::time_point deadline) {
  for (;;) {
    if (auto nl = inbuf_.find('\n'); nl != std::string::npos) {
      std::string line = inbuf_.substr(0, nl);
      inbuf_.erase(0, nl + 1);
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      if (rpc::nests_deeper_than(line, rpc::max_nesting_depth)) {
        // Not parsed: printing or comparing a deeper tree recurses per level.
        throw ProtocolError("hapticd at " + path_ + " sent a line nesting arrays and objects more than " +
                            std::to_string(rpc::max_nesting_depth) + " levels deep");
      }
      auto msg = nlohmann::json::parse(line, nullptr, false);
      if (msg.is_discarded() || !msg.is_object()) {
        throw ProtocolError("hapticd at " + path_ +
                            " sent a line that is not a JSON object: " + line.substr(0, 200));
      }
      return msg;
    }
    if (inbuf_.size() > max_line_bytes)
      throw ProtocolError("hapticd sent a line longer than the client accepts");
    pollfd p{fd_, POLLIN, 0};
    int r = ::poll(&p, 1, remaining_ms(deadline));
    if (r < 0) {
      if (errno == EINTR) {
        // Let a signal handler's flag be seen by the caller's loop.
        return std::nullopt;
      }
      lost("poll: " + errno_text(errno), errno);
    }
    if (r == 0) return std::nullopt;
    char buf[65536];
    ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
    if (n > 0) {
      inbuf_.append(buf, static_cast<std::size_t>(n));
    } else if (n == 0) {
      lost("the daemon closed the connection", 0);
    } else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      lost("recv: " + errno_text(errno), errno);
    }
  }
}

nlohmann::json Client::call(const std::string& method, const nlohmann::json& params) {
  const std::int64_t id = next_id_++;
  nlohmann::json request{{"jsonrpc", rpc::version}, {"id", id}, {"method", method}, {"params", params}};
  send_line(rpc::to_line(request));
  auto deadline = Clock::now() + timeout_;
  for (;;) {
    auto msg = next_message(deadline);
    if (!msg) {
      if (Clock::now() < deadline) continue;  // EINTR
      throw ConnectError("hapticd at " + path_ + " did not answer '" + method + "' within " +
                             std::to_string(timeout_.count()) + " ms",
                         path_, ETIMEDOUT);
    }
    if (!msg->contains("id")) {
      if (msg->contains("method")) {
        notifications_.push_back(std::move(*msg));
        continue;
      }
      throw ProtocolError("hapticd sent a message with neither id nor method");
    }
    const auto& msg_id = (*msg)["id"];
    if (msg->contains("error")) {
      // An error for our id, or an unsolicited one (id null: busy, too large, parse error).
      if (msg_id == id || msg_id.is_null()) throw_error_object((*msg)["error"]);
      continue;  // an answer to an earlier request that timed out
    }
    if (msg_id != id) continue;
    if (!msg->contains("result"))
      throw ProtocolError("hapticd sent a response with neither result nor error");
    if ((*msg).value("jsonrpc", std::string()) != rpc::version) {
      throw ProtocolError("hapticd sent a response without \"jsonrpc\":\"2.0\"");
    }
    return std::move((*msg)["result"]);
  }
}

void Client::notify(const std::string& method, const nlohmann::json& params) {
  send_line(rpc::to_line({{"jsonrpc", rpc::version}, {"method", method}, {"params", params}}));
}

nlohmann::json Client::subscribe(double rate_hz, const std::vector<std::string>& channels) {
  nlohmann::json params{{"rate_hz", rate_hz}};
  if (!channels.empty()) params["channels"] = channels;
  return call("stream", params);
}

nlohmann::json Client::unsubscribe() { return call("stream.stop"); }

std::optional<nlohmann::json> Client::read_notification(std::chrono::milliseconds timeout) {
  if (!notifications_.empty()) {
    auto n = std::move(notifications_.front());
    notifications_.pop_front();
    return n;
  }
  auto deadline = Clock::now() + timeout;
  for (;;) {
    auto msg = next_message(deadline);
    if (!msg) return std::nullopt;
    if (msg->contains("method") && !msg->contains("id")) return msg;
    if (msg->contains("error") && msg->contains("id") && (*msg)["id"].is_null())
      throw_error_object((*msg)["error"]);
    // A stray response (to a request that timed out): skip it.
  }
}

}  // namespace hapticd::client
