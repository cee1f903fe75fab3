#pragma once
/// \file
/// A connection to hapticd's control socket (docs/protocol.md). Blocking
/// calls with a timeout; not thread-safe (one connection per thread).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "client/errors.hpp"

namespace hapticd::client {

class Client {
 public:
  /// Connects to the daemon's socket. Throws ConnectError (with errno and a
  /// message naming the path) when nobody answers there.
  static Client connect(const std::string& path, std::chrono::milliseconds timeout);

  Client(Client&& other) noexcept;
  Client& operator=(Client&& other) noexcept;
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  ~Client();

  /// Sends a request and waits for its response; notifications that arrive
  /// meanwhile are queued for read_notification(). Returns the result.
  /// Throws RpcError (the daemon answered with an error, including an
  /// unsolicited one such as busy), ConnectError (connection lost or no
  /// answer within the timeout) or ProtocolError (not a JSON-RPC response).
  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object());

  /// Sends a notification (a request without id: the daemon does not answer).
  void notify(const std::string& method, const nlohmann::json& params = nlohmann::json::object());

  /// `stream {rate_hz, channels}`; returns the daemon's result.
  nlohmann::json subscribe(double rate_hz, const std::vector<std::string>& channels = {});
  /// `stream.stop`; returns the daemon's result.
  nlohmann::json unsubscribe();

  /// The next notification ({"jsonrpc","method","params"}), or nullopt if none
  /// arrives within the timeout. Throws like call() when the connection fails.
  std::optional<nlohmann::json> read_notification(std::chrono::milliseconds timeout);

  /// Time allowed for each call(); default: the connect timeout.
  void set_timeout(std::chrono::milliseconds timeout) noexcept { timeout_ = timeout; }
  const std::string& path() const noexcept { return path_; }
  /// The socket (for poll()); owned by the Client.
  int fd() const noexcept { return fd_; }

  /// Longest line accepted from the daemon (a stream sample or a status).
  static constexpr std::size_t max_line_bytes = std::size_t{16} * 1024 * 1024;

 private:
  Client(int fd, std::string path, std::chrono::milliseconds timeout);
  void send_line(const std::string& line);
  /// Reads until a complete message is available or the deadline passes.
  std::optional<nlohmann::json> next_message(std::chrono::steady_clock::time_point deadline);
  [[noreturn]] void lost(const std::string& what, int error_number);

  int fd_ = -1;
  std::string path_;
  std::chrono::milliseconds timeout_;
  std::int64_t next_id_ = 1;
  std::string inbuf_;
  std::deque<nlohmann::json> notifications_;
};

}  // namespace hapticd::client
