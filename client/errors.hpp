#pragma once
/// \file
/// Typed exceptions of the client library. The daemon's own error replies
/// arrive as hapticd::rpc::RpcError (code, message, data).

#include <stdexcept>
#include <string>

#include "rpc/jsonrpc.hpp"

namespace hapticd::client {

using rpc::RpcError;

/// The daemon cannot be reached: no socket, nobody listening, permission
/// denied on the socket, the connection dropped, or no answer in time.
class ConnectError : public std::runtime_error {
 public:
  ConnectError(const std::string& message, std::string path, int error_number)
      : std::runtime_error(message), path_(std::move(path)), errno_(error_number) {}
  const std::string& path() const noexcept { return path_; }
  /// errno of the failing call; 0 when not a system call (EOF, timeout).
  int error_number() const noexcept { return errno_; }

 private:
  std::string path_;
  int errno_;
};

/// The peer does not speak the protocol: a reply that is not JSON, not a
/// JSON-RPC 2.0 response, or a line longer than the client accepts.
class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace hapticd::client
