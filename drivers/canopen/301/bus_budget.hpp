#pragma once
/// \file
/// How many bits a period's frames take on a classic CAN bus, worst case.
/// A data frame with an 11-bit identifier and s data bytes has 34 + 8 s bits
/// subject to stuffing (SOF, identifier, RTR, IDE, r0, DLC, data, CRC), at
/// most one stuff bit per 4 of them after the first, then 13 bits that are
/// never stuffed (CRC delimiter, ACK slot and delimiter, 7 EOF, 3 intermission):
///   bits(s) = 34 + 8 s + 13 + floor((34 + 8 s - 1) / 4)
/// (Davis, Burns, Bril, Lukkien, "Controller Area Network (CAN) schedulability
/// analysis: refuted, revisited and revised", Real-Time Systems 35, 2007):
/// 55 bits for the empty SYNC, 135 bits for 8 bytes.
///
/// The budget of one period is the cyclic frames (SYNC, RPDO, TPDOs) plus one
/// 8-byte frame of blocking: CAN does not pre-empt a frame already on the
/// wire, so a heartbeat, EMCY or SDO frame that started just before the SYNC
/// delays the cycle by up to 135 bits.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace hapticd::drivers::canopen::cia301 {

constexpr std::uint32_t frame_bits_worst_case(std::size_t data_bytes) noexcept {
  const std::uint32_t stuffed = 34U + 8U * static_cast<std::uint32_t>(data_bytes);
  return stuffed + 13U + (stuffed - 1U) / 4U;
}
inline constexpr std::uint32_t blocking_frame_bits = frame_bits_worst_case(8);

/// The bit rates CiA 301 lists for classic CAN, bit/s, fastest first.
inline constexpr std::uint32_t standard_bitrates[] = {1000000, 800000, 500000, 250000,
                                                      125000,  50000,  20000,  10000};
inline constexpr std::uint32_t max_classic_bitrate = 1000000;

struct CyclicFrame {
  std::string_view name;  ///< "SYNC", "RPDO1", "TPDO1" ...
  std::size_t bytes = 0;
};

struct BusBudget {
  std::uint32_t cyclic_bits = 0;    ///< the period's own frames, worst-case stuffing
  std::uint32_t blocking_bits = 0;  ///< one 8-byte frame of other traffic
  std::uint32_t total_bits = 0;
  std::size_t frames = 0;
  double period_s = 0.0;
  std::uint32_t bitrate = 0;
  double bus_time_s = 0.0;           ///< total_bits / bitrate
  bool fits = false;                 ///< bus_time_s <= period_s
  double shortest_period_s = 0.0;    ///< at this bit rate
  std::uint32_t needed_bitrate = 0;  ///< smallest standard bit rate that carries this period; 0 if none does
  std::string summary;               ///< one line with the figures (for refusals and for the log)
};

/// Throws std::invalid_argument for a non-positive period or bit rate.
BusBudget check_bus_budget(std::span<const CyclicFrame> frames, double period_s, std::uint32_t bitrate);

/// "1 Mbit/s", "500 kbit/s", "83.3 kbit/s".
std::string format_bitrate(double bits_per_second);
/// "0.25 ms", "1 ms", "265 us".
std::string format_duration(double seconds);

}  // namespace hapticd::drivers::canopen::cia301
