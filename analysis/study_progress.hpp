#pragma once
/// \file
/// Progress and cancellation for the long studies (accuracy, stability
/// sweep). The study says how much work it plans and reports what it has
/// done; the front end's callback shows it and may ask to stop, which ends
/// the study with StudyCancelled before any result is returned (so a
/// caller never writes half a study).

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

namespace hapticd::analysis {

struct StudyCancelled : std::runtime_error {
  StudyCancelled() : std::runtime_error("study stopped before it finished") {}
};

/// CPU time in seconds, for the measured costs (injected so that analysis/
/// makes no OS call of its own; process_cpu_seconds is std::clock()).
using CpuClock = double (*)();
double process_cpu_seconds() noexcept;

class StudyProgress {
 public:
  /// fraction done in [0, 1], what is running; returns false to stop.
  using Callback = std::function<bool(double fraction, const std::string& stage)>;

  StudyProgress() = default;
  explicit StudyProgress(Callback callback, CpuClock cpu_clock = process_cpu_seconds)
      : callback_(std::move(callback)), clock_(cpu_clock) {}

  CpuClock clock() const noexcept { return clock_; }
  void plan(double total_units) noexcept { total_ += total_units; }
  void stage(std::string label) {
    stage_ = std::move(label);
    report();
  }
  /// Counts `units` as done; throws StudyCancelled if the callback says stop.
  void advance(double units) {
    done_ += units;
    report();
  }

 private:
  void report() {
    if (callback_ && !callback_(total_ > 0.0 ? done_ / total_ : 0.0, stage_)) throw StudyCancelled();
  }
  Callback callback_;
  CpuClock clock_ = process_cpu_seconds;
  double total_ = 0.0;
  double done_ = 0.0;
  std::string stage_;
};

}  // namespace hapticd::analysis
