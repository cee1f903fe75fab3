#include "drivers/canopen/301/bus_budget.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace hapticd::drivers::canopen::cia301 {
namespace {

std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

}  // namespace

std::string format_bitrate(double bits_per_second) {
  if (bits_per_second >= 1e6) return format_number(bits_per_second / 1e6) + " Mbit/s";
  if (bits_per_second >= 1e3) return format_number(bits_per_second / 1e3) + " kbit/s";
  return format_number(bits_per_second) + " bit/s";
}

std::string format_duration(double seconds) {
  if (seconds >= 1.0) return format_number(seconds) + " s";
  if (seconds >= 1e-4) return format_number(seconds * 1e3) + " ms";
  return format_number(seconds * 1e6) + " us";
}

BusBudget check_bus_budget(std::span<const CyclicFrame> frames, double period_s, std::uint32_t bitrate) {
  if (!(period_s > 0.0) || !std::isfinite(period_s))
    throw std::invalid_argument("bus budget: period must be > 0");
  if (bitrate == 0) throw std::invalid_argument("bus budget: bit rate must be > 0");
  BusBudget b;
  b.frames = frames.size();
  std::string names;
  for (const CyclicFrame& f : frames) {
    b.cyclic_bits += frame_bits_worst_case(f.bytes);
    if (!names.empty()) names += " + ";
    names += f.name;
  }
  b.blocking_bits = blocking_frame_bits;
  b.total_bits = b.cyclic_bits + b.blocking_bits;
  b.period_s = period_s;
  b.bitrate = bitrate;
  b.bus_time_s = b.total_bits / static_cast<double>(bitrate);
  // A decimal period is not exact in binary ("400us" = 400 * 1e-6 s is a hair
  // under 400 bit times at 1 Mbit/s): compare in bit times, rounding off the
  // representation error (1e-9 of a period, far below one bit).
  const double bit_times = period_s * bitrate * (1.0 + 1e-9);
  b.fits = b.total_bits <= bit_times;
  b.shortest_period_s = b.bus_time_s;
  const double needed = b.total_bits / (period_s * (1.0 + 1e-9));
  for (auto it = std::rbegin(standard_bitrates); it != std::rend(standard_bitrates); ++it) {
    if (*it >= needed) {
      b.needed_bitrate = *it;
      break;
    }
  }
  b.summary = std::to_string(b.frames) + " frames (" + names + ") = " + std::to_string(b.cyclic_bits) +
              " bits worst case, + " + std::to_string(b.blocking_bits) +
              " bits for one frame of other traffic = " + format_duration(b.bus_time_s) + " at " +
              format_bitrate(bitrate);
  if (b.fits) {
    b.summary += ", within the " + format_duration(period_s) + " period";
  } else {
    b.summary += ": a " + format_duration(period_s) + " period needs ";
    b.summary += b.needed_bitrate != 0 ? format_bitrate(b.needed_bitrate)
                                       : format_bitrate(needed) + ", above classic CAN's " +
                                             format_bitrate(max_classic_bitrate);
    b.summary +=
        "; the shortest period at " + format_bitrate(bitrate) + " is " + format_duration(b.shortest_period_s);
  }
  return b;
}

}  // namespace hapticd::drivers::canopen::cia301
