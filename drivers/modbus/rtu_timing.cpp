#include "drivers/modbus/rtu_timing.hpp"

#include <array>

namespace hapticd::drivers::modbus {

namespace {

// Rates libmodbus 3.1.6 turns into a termios speed on Linux. Checked on
// Debian 12 (libmodbus5 3.1.6-2.1) against a pseudo-terminal: 2000000 and
// 14400 are missing from its table and silently become B9600.
constexpr std::array<int, 22> bauds = {300,     600,     1200,    2400,    4800,    9600,   19200,  38400,
                                       57600,   115200,  230400,  460800,  500000,  576000, 921600, 1000000,
                                       1152000, 1500000, 2500000, 3000000, 3500000, 4000000};

// Modbus over serial line V1.02, 2.5.1.1: above 19200 baud, t3.5 = 1.750 ms.
constexpr double spec_fixed_silence_s = 1.75e-3;
constexpr int spec_fixed_silence_above_baud = 19200;

}  // namespace

int character_bits(const SerialFormat& format) noexcept {
  return 1 + format.data_bits + (format.parity == Parity::none ? 0 : 1) + format.stop_bits;
}

double character_time_s(const SerialFormat& format) noexcept {
  return static_cast<double>(character_bits(format)) / static_cast<double>(format.baud);
}

double frame_silence_s(const SerialFormat& format, SilenceRule rule) noexcept {
  if (rule == SilenceRule::spec && format.baud > spec_fixed_silence_above_baud) return spec_fixed_silence_s;
  return 3.5 * character_time_s(format);
}

TransactionTime transaction_time(const SerialFormat& format, SilenceRule rule, double turnaround_s,
                                 int request_bytes, int response_bytes) noexcept {
  const double t_char = character_time_s(format);
  TransactionTime t;
  t.request_bytes = request_bytes;
  t.response_bytes = response_bytes;
  t.request_s = request_bytes * t_char;
  t.silence_s = frame_silence_s(format, rule);
  t.turnaround_s = turnaround_s;
  t.response_s = response_bytes * t_char;
  return t;
}

CycleTime cycle_time(const SerialFormat& format, SilenceRule rule, double turnaround_s, bool function_23,
                     int write_registers, int read_registers) noexcept {
  CycleTime c;
  if (function_23) {
    c.transactions = 1;
    c.first = transaction_time(format, rule, turnaround_s, rtu_bytes::write_and_read_request(write_registers),
                               rtu_bytes::write_and_read_response(read_registers));
  } else {
    c.transactions = 2;
    c.first = transaction_time(format, rule, turnaround_s, rtu_bytes::write_multiple_request(write_registers),
                               rtu_bytes::write_multiple_response());
    c.second = transaction_time(format, rule, turnaround_s, rtu_bytes::read_request(),
                                rtu_bytes::read_response(read_registers));
  }
  return c;
}

double shortest_period_s(const CycleTime& cycle, double link_budget) noexcept {
  return cycle.total_s() / link_budget;
}

bool is_supported_baud(int baud) noexcept {
  for (int b : bauds)
    if (b == baud) return true;
  return false;
}

const int* supported_bauds(int& count) noexcept {
  count = static_cast<int>(bauds.size());
  return bauds.data();
}

int lowest_baud_for(const SerialFormat& format, SilenceRule rule, double turnaround_s, bool function_23,
                    int write_registers, int read_registers, double period_s, double link_budget) noexcept {
  for (int b : bauds) {
    SerialFormat f = format;
    f.baud = b;
    const CycleTime c = cycle_time(f, rule, turnaround_s, function_23, write_registers, read_registers);
    if (c.total_s() <= link_budget * period_s) return b;
  }
  return 0;
}

}  // namespace hapticd::drivers::modbus
