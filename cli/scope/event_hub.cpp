#include "cli/scope/event_hub.hpp"

namespace hapticd::cli::scope {

void EventHub::publish(const std::string& event, const std::string& data, bool sticky) {
  std::string text = "event: " + event + "\ndata: " + data + "\n\n";
  {
    std::lock_guard lock(mutex_);
    if (sticky) sticky_[event] = text;
    events_.push_back(std::move(text));
    while (events_.size() > keep_) {
      events_.pop_front();
      ++first_;
    }
  }
  wake_.notify_all();
}

std::string EventHub::join(std::uint64_t& next) const {
  std::lock_guard lock(mutex_);
  std::string out;
  for (const auto& [event, text] : sticky_) out += text;
  for (const auto& text : events_) out += text;
  next = first_ + events_.size();
  return out;
}

std::optional<std::string> EventHub::read(std::uint64_t& next, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, timeout, [&] { return closed_ || first_ + events_.size() > next; });
  if (closed_) return std::nullopt;
  if (next < first_) next = first_;  // this page fell behind by more than `keep`: it skips
  std::string out;
  for (; next < first_ + events_.size(); ++next) out += events_[next - first_];
  return out;
}

void EventHub::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  wake_.notify_all();
}

}  // namespace hapticd::cli::scope
