#pragma once
/// \file
/// The simulated encoder/motor board: the firmware logic (board_firmware.hpp)
/// between the USB endpoints and a plant, speaking the protocol note's
/// default reports with its own decoder (board_reports.hpp). A new OUT report applies its
/// command and advances the plant by exactly one period (DRIVERS.md: a peer
/// advances its plant one period per exchange), then the board has a new IN
/// report with the encoder count. So a run is deterministic and comparable
/// sample by sample with the loopback run of the same plant.
///
/// Threads: every member may be called from any thread (one mutex: this is
/// the peer, not the RT path).

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/usb_hid/board_firmware.hpp"

namespace hapticd::drivers::usb_hid::sim {

/// What the board drives. The shared plant simulator
/// (drivers/simulation/PlantSimulator) has exactly this shape.
class BoardPlant {
 public:
  virtual ~BoardPlant() = default;
  /// The encoder's position now (m or rad).
  virtual IoResult sense(double& position) noexcept = 0;
  /// Applies `force` (N or N m) for one period and advances the plant.
  virtual IoResult step(double force) noexcept = 0;
};

/// The shared plant simulator behind the board (drivers/simulation), so a
/// board run compares sample by sample with a loopback run of the same plant.
class SimulatorPlant final : public BoardPlant {
 public:
  explicit SimulatorPlant(simulation::PlantSimulator& simulator) : simulator_(simulator) {}
  IoResult sense(double& position) noexcept override { return simulator_.sense(position); }
  IoResult step(double force) noexcept override { return simulator_.step(force); }

 private:
  simulation::PlantSimulator& simulator_;
};

struct BoardScaling {
  double position_per_count = 2.0 * 3.14159265358979323846 / 16384.0;  ///< rad or m per encoder count
  double command_full_scale = 1.0;                                     ///< N m or N at the largest command
  double period_s = 1e-3;  ///< plant step per OUT report (deterministic clock)
};

/// One axis of a board with several: its plant and its scales.
struct BoardAxis {
  BoardPlant* plant = nullptr;
  double position_per_count = 1.0 / 16384.0;  ///< m per encoder count
  double command_full_scale = 1.0;            ///< N at the largest command
};

/// Where the board's microsecond clock comes from.
enum class BoardClock {
  deterministic,  ///< + period per new OUT report, + advance_time(): repeatable runs
  wall,           ///< steady_clock since power-on: the dead-man trips when the host goes quiet
};

struct BoardSnapshot {
  FirmwareCounters firmware;
  std::int64_t output_counts = 0;
  double applied_force = 0.0;  ///< N or N m the plant got over the last step
  bool output_on = false;
  bool watchdog_tripped = false;
  std::uint32_t fault_code = 0;
  std::uint64_t steps = 0;  ///< plant periods
  std::uint64_t now_us = 0;
  /// Every axis' (output_counts and applied_force are axis 1's).
  std::array<std::int64_t, max_board_axes> outputs{};
  std::array<double, max_board_axes> applied_forces{};
};

class SimulatedBoard {
 public:
  SimulatedBoard(const BoardScaling& scaling, BoardPlant& plant,
                 BoardClock clock = BoardClock::deterministic);
  /// A board with several axes (1 to max_board_axes), each with its plant
  /// (every plant steps once per new OUT report) and its scales.
  SimulatedBoard(const std::vector<BoardAxis>& axes, double period_s,
                 BoardClock clock = BoardClock::deterministic);

  // ---- the USB side (the emulated endpoints) ----
  /// An OUT report: the firmware applies it; a new one steps the plant one
  /// period and makes a new IN report.
  void on_out_report(std::span<const std::uint8_t> bytes);
  /// Copies the newest IN report not yet sent into `buffer`; false if none
  /// (the endpoint NAKs the IN token). Returns its length in `length`.
  bool take_in_report(std::span<std::uint8_t> buffer, std::size_t& length);
  /// A fresh IN report with the current state: a host that starts polling
  /// (claims the interface) gets one at the first IN token, as from a board
  /// that samples every interval. Otherwise reports come one per new OUT.
  void refresh_report();
  /// Firmware restart (plug-in): new sequence numbers, faults cleared, the
  /// power-on IN report ready. The plant keeps its state.
  void power_on();

  // ---- the test side ----
  /// Advances the deterministic clock and runs the dead-man tick.
  void advance_time_us(std::uint64_t us);
  /// Runs the dead-man tick at the current time (the wall clock's frame tick).
  void tick();
  void raise_fault(FaultCode code, bool cause_present = true);
  void clear_cause();
  /// The next IN report goes out one byte short (a firmware or bus fault).
  /// Lock-free: a BoardPlant may call it from step() (a scheduled glitch).
  void truncate_next_report() noexcept { truncate_next_.store(true, std::memory_order_release); }
  /// Axis `axis`'s encoder reads `counts` more from now on (a glitch).
  void offset_encoder(std::size_t axis, std::int64_t counts);
  std::size_t axes() const noexcept { return axes_.size(); }
  /// The IN and OUT report sizes this board speaks.
  std::size_t in_report_size() const noexcept { return in_report_bytes_for(axes_.size()); }
  std::size_t out_report_size() const noexcept { return out_report_bytes_for(axes_.size()); }
  BoardSnapshot snapshot() const;

 private:
  std::uint64_t now_us_locked() const;
  void make_report_locked();

  const std::vector<BoardAxis> axes_;
  const double period_s_;
  const BoardClock clock_;

  mutable std::mutex mutex_;
  BoardFirmware firmware_;
  std::chrono::steady_clock::time_point powered_at_;
  std::uint64_t deterministic_us_ = 0;
  std::uint64_t steps_ = 0;
  std::array<double, max_board_axes> applied_forces_{};
  std::array<std::int64_t, max_board_axes> encoder_offsets_{};
  std::atomic<bool> truncate_next_{false};
  std::uint8_t pending_[max_in_report_bytes]{};
  std::size_t pending_length_ = 0;  ///< 0: no report waiting
};

/// Runs the board's frame tick on the wall clock (every `interval`) on its
/// own thread, as a real board's start-of-frame interrupt does: with
/// BoardClock::wall the dead-man trips when the host goes quiet.
class FrameTicker {
 public:
  FrameTicker(SimulatedBoard& board, std::chrono::microseconds interval = std::chrono::microseconds(1000));
  ~FrameTicker();
  FrameTicker(const FrameTicker&) = delete;
  FrameTicker& operator=(const FrameTicker&) = delete;

 private:
  SimulatedBoard& board_;
  std::chrono::microseconds interval_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace hapticd::drivers::usb_hid::sim
