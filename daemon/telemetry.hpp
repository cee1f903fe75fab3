#pragma once
/// \file
/// One telemetry sample per period, pushed by the RT thread into an SPSC ring
/// and written out by non-RT consumers (recorder, live streams). Trivially
/// copyable, fixed size. Which `channels` entries are meaningful, and their
/// names and units, is described once per loaded scene (ChannelDescription):
/// a sample carries only the channels the scene and device produce.

#include <array>
#include <cstdint>
#include <string>
#include <type_traits>

namespace hapticd::daemon {

/// The scene's channels (10 at most), after three per axis on a device with
/// several (position, task force, joint output: 18 for 6 axes), one more per
/// axis with [gravity] and one with [workspace] (26 for 6 axes and a wall).
inline constexpr std::size_t max_telemetry_channels = 26;

/// Bits in TelemetrySample::flags.
enum TelemetryFlag : std::uint32_t {
  flag_fault_latched = 1u << 0,    ///< output held at zero by a latched fault
  flag_torque_limited = 1u << 1,   ///< the torque limit clipped the scene's command
  flag_read_error = 1u << 2,       ///< device read failed this period
  flag_overrun = 1u << 3,          ///< this cycle woke past its deadline by more than a period
  flag_unstable_forced = 1u << 4,  ///< scene loaded with force=true although unstable
  flag_position_jump = 1u << 5,    ///< the reading stepped beyond max_velocity: not rendered, output zero
  flag_stale_position = 1u << 6,   ///< the device had no new sample: its last position was rendered
  /// [device] require_calibration and no origin in force yet: output held at zero.
  flag_uncalibrated = 1u << 7,
};

struct TelemetrySample {
  std::uint64_t cycle = 0;
  double time_s = 0.0;     ///< since loop start (simulated time with the virtual clock)
  double position = 0.0;   ///< measured, m or rad
  double command = 0.0;    ///< scene output before the limit, N or N m
  double applied = 0.0;    ///< sent to the device, N or N m
  double latency_s = 0.0;  ///< wake-up latency of this cycle
  double compute_s = 0.0;  ///< read + step + write time of this cycle
  std::uint32_t flags = 0;
  std::uint32_t channel_count = 0;
  std::array<double, max_telemetry_channels> channels{};  ///< scene then device channels
};
static_assert(std::is_trivially_copyable_v<TelemetrySample>);

/// Name and SI unit of one entry of TelemetrySample::channels.
struct ChannelDescription {
  std::string name;
  std::string unit;
};

}  // namespace hapticd::daemon
