#pragma once
/// \file
/// The scope's server-sent events: one producer (the daemon feed) publishes
/// events, each page connection reads them from its own position. The last
/// `keep` events stay for a page that connects late (its plot starts with
/// the window it missed), and the latest of each sticky kind (meta, status)
/// is sent first to every new page whatever has scrolled out.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace hapticd::cli::scope {

class EventHub {
 public:
  explicit EventHub(std::size_t keep) : keep_(keep) {}

  /// "event: <event>\ndata: <data>\n\n" to every page; sticky: also the one
  /// sent first to pages that connect later.
  void publish(const std::string& event, const std::string& data, bool sticky = false);

  /// A new page: the sticky events and the retained ones; `next` is where it
  /// goes on reading.
  std::string join(std::uint64_t& next) const;
  /// Events from `next` on, waiting up to `timeout` for one; "" on timeout;
  /// nullopt once closed.
  std::optional<std::string> read(std::uint64_t& next, std::chrono::milliseconds timeout) const;

  void close();  ///< wakes every reader; they end their responses

 private:
  const std::size_t keep_;
  mutable std::mutex mutex_;
  mutable std::condition_variable wake_;
  std::deque<std::string> events_;  ///< events_[i] has sequence number first_ + i
  std::uint64_t first_ = 0;
  std::map<std::string, std::string> sticky_;
  bool closed_ = false;
};

}  // namespace hapticd::cli::scope
