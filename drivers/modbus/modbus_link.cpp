#include "drivers/modbus/modbus_link.hpp"

#include <modbus.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_frame.hpp"

namespace hapticd::drivers::modbus {

namespace {

struct TimeoutParts {
  std::uint32_t sec = 0, usec = 0;
};

TimeoutParts split_seconds(double seconds) {
  const auto us = static_cast<std::uint64_t>(std::llround(seconds * 1e6));
  return {static_cast<std::uint32_t>(us / 1000000u), static_cast<std::uint32_t>(us % 1000000u)};
}

char parity_letter(Parity parity) {
  return parity == Parity::none ? 'N' : parity == Parity::even ? 'E' : 'O';
}

std::string system_error(int error_number) { return modbus_strerror(error_number); }

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", s);
  return text;
}

}  // namespace

LinkOutcome classify_error(int error_number, std::uint8_t& exception_code) noexcept {
  exception_code = 0;
  if (error_number > MODBUS_ENOBASE && error_number < MODBUS_ENOBASE + MODBUS_EXCEPTION_MAX) {
    exception_code = static_cast<std::uint8_t>(error_number - MODBUS_ENOBASE);
    return LinkOutcome::exception;
  }
  switch (error_number) {
    case ETIMEDOUT:
      return LinkOutcome::timeout;
    case EMBBADCRC:
      return LinkOutcome::crc_error;
    case EMBBADDATA:
    case EMBBADEXC:
    case EMBUNKEXC:
    case EMBMDATA:
    case EMBBADSLAVE:
      return LinkOutcome::bad_frame;
    case ECONNRESET:
    case ECONNREFUSED:
    case ECONNABORTED:
    case EPIPE:
    case ENOTCONN:
    case EBADF:
    case EIO:  // a serial device unplugged, a pseudo-terminal whose master closed
    case ENXIO:
      return LinkOutcome::closed;
    default:
      return LinkOutcome::io_error;
  }
}

const char* outcome_name(LinkOutcome outcome) noexcept {
  switch (outcome) {
    case LinkOutcome::ok:
      return "ok";
    case LinkOutcome::timeout:
      return "timeout";
    case LinkOutcome::crc_error:
      return "CRC error";
    case LinkOutcome::exception:
      return "exception";
    case LinkOutcome::bad_frame:
      return "malformed reply";
    case LinkOutcome::closed:
      return "connection closed";
    case LinkOutcome::io_error:
      return "I/O error";
  }
  return "?";
}

std::string describe(const LinkResult& r) {
  char fc[8];
  std::snprintf(fc, sizeof fc, "0x%02X", r.function);
  const std::string to = std::string(" in reply to function ") + fc;
  switch (r.outcome) {
    case LinkOutcome::ok:
      return "ok";
    case LinkOutcome::exception: {
      char code[8];
      std::snprintf(code, sizeof code, "0x%02X", r.exception_code);
      return std::string("exception ") + code + " (" + std::string(exception_name(r.exception_code)) + ")" +
             to;
    }
    case LinkOutcome::timeout:
      return std::string("no response within the response timeout") + " to function " + fc;
    case LinkOutcome::crc_error:
      return "CRC error" + to;
    case LinkOutcome::bad_frame:
      return "malformed reply" + to + " (" + system_error(r.error_number) + ")";
    case LinkOutcome::closed:
      return "connection closed (" + system_error(r.error_number) + ")";
    case LinkOutcome::io_error:
      return "I/O error (" + system_error(r.error_number) + ")";
  }
  return "?";
}

ModbusLink::ModbusLink(LinkSettings settings) : settings_(std::move(settings)) {
  if (settings_.transport == Transport::tcp) {
    const std::string service = std::to_string(settings_.port);
    ctx_ = modbus_new_tcp_pi(settings_.host.c_str(), service.c_str());
    if (!ctx_)
      throw LinkError("host",
                      "cannot make a Modbus TCP context for " + settings_.host + ": " + system_error(errno));
  } else {
    ctx_ = modbus_new_rtu(settings_.device.c_str(), settings_.serial.baud,
                          parity_letter(settings_.serial.parity), settings_.serial.data_bits,
                          settings_.serial.stop_bits);
    if (!ctx_)
      throw LinkError(
          "device", "cannot make a Modbus RTU context for " + settings_.device + ": " + system_error(errno));
  }
  // Recovery would sleep a whole response timeout and reconnect inside a
  // transaction, on the RT thread; the device decides instead.
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_NONE);
  if (modbus_set_slave(ctx_, settings_.slave_id) != 0)
    throw LinkError("slave_id", "libmodbus refuses slave id " + std::to_string(settings_.slave_id) + ": " +
                                    system_error(errno));
}

ModbusLink::~ModbusLink() {
  close();
  modbus_free(ctx_);
}

std::string ModbusLink::endpoint() const {
  if (settings_.transport == Transport::tcp)
    return "tcp " + settings_.host + ":" + std::to_string(settings_.port) + " unit " +
           std::to_string(settings_.slave_id);
  const SerialFormat& s = settings_.serial;
  return "rtu " + settings_.device + " " + std::to_string(s.baud) + " " + std::to_string(s.data_bits) +
         parity_letter(s.parity) + std::to_string(s.stop_bits) + " slave " +
         std::to_string(settings_.slave_id);
}

void ModbusLink::apply_timeouts() {
  const TimeoutParts response = split_seconds(settings_.response_timeout_s);
  if (modbus_set_response_timeout(ctx_, response.sec, response.usec) != 0)
    throw LinkError("response_timeout", "libmodbus refuses a response timeout of " +
                                            std::to_string(settings_.response_timeout_s) +
                                            " s: " + system_error(errno));
  const TimeoutParts byte = split_seconds(settings_.byte_timeout_s);
  if (modbus_set_byte_timeout(ctx_, byte.sec, byte.usec) != 0)
    throw LinkError("byte_timeout", "libmodbus refuses a byte timeout of " +
                                        std::to_string(settings_.byte_timeout_s) +
                                        " s: " + system_error(errno));
}

void ModbusLink::set_response_timeout(double seconds) {
  settings_.response_timeout_s = seconds;
  apply_timeouts();
}

void ModbusLink::open() {
  if (open_) return;
  // libmodbus 3.1.6 bounds a TCP connect() by the response timeout.
  const TimeoutParts connect = split_seconds(settings_.connect_timeout_s);
  modbus_set_response_timeout(ctx_, connect.sec, connect.usec);
  if (modbus_connect(ctx_) != 0) {
    const int e = errno;
    if (settings_.transport == Transport::tcp)
      throw LinkError("host", "cannot connect to Modbus TCP " + settings_.host + ":" +
                                  std::to_string(settings_.port) + " within " +
                                  seconds_text(settings_.connect_timeout_s) + ": " + system_error(e));
    throw LinkError("device", "cannot open serial device " + settings_.device + ": " + system_error(e));
  }
  open_ = true;
  if (settings_.transport == Transport::rtu && settings_.rs485 &&
      modbus_rtu_set_serial_mode(ctx_, MODBUS_RTU_RS485) != 0) {
    const int e = errno;
    close();
    throw LinkError("rs485", settings_.device + " refuses RS-485 mode (TIOCSRS485: " + system_error(e) +
                                 "): its kernel driver cannot switch the transceiver; use an adapter that "
                                 "switches direction by itself and set rs485 = false");
  }
  try {
    apply_timeouts();
  } catch (...) {
    close();
    throw;
  }
}

void ModbusLink::close() noexcept {
  flush_before_next_ = false;
  if (!open_) return;
  modbus_close(ctx_);
  open_ = false;
}

void ModbusLink::reopen() {
  close();
  open();
  counters_.reconnects.fetch_add(1, std::memory_order_relaxed);
}

bool ModbusLink::ready() noexcept {
  if (!open_) return false;
  if (flush_before_next_) {
    modbus_flush(ctx_);
    flush_before_next_ = false;
  }
  return true;
}

LinkResult ModbusLink::finish(int rc, std::uint8_t function) noexcept {
  LinkResult r;
  r.function = function;
  counters_.requests.fetch_add(1, std::memory_order_relaxed);
  if (rc >= 0) {
    counters_.responses.fetch_add(1, std::memory_order_relaxed);
    return r;
  }
  r.error_number = errno;
  r.outcome = classify_error(r.error_number, r.exception_code);
  auto bump = [](std::atomic<std::uint64_t>& c) { c.fetch_add(1, std::memory_order_relaxed); };
  switch (r.outcome) {
    case LinkOutcome::ok:
      break;
    case LinkOutcome::timeout:
      bump(counters_.timeouts);
      break;
    case LinkOutcome::crc_error:
      bump(counters_.responses);
      bump(counters_.crc_errors);
      break;
    case LinkOutcome::exception:
      bump(counters_.responses);
      bump(counters_.exceptions);
      break;
    case LinkOutcome::bad_frame:
      bump(counters_.responses);
      bump(counters_.bad_frames);
      break;
    case LinkOutcome::closed:
      bump(counters_.closed);
      break;
    case LinkOutcome::io_error:
      bump(counters_.io_errors);
      break;
  }
  // A late or partial reply must not be taken for the next one (libmodbus
  // 3.1.6 does not skip a reply with another transaction id, it fails):
  // drop what is buffered now, and again before the next request, by which
  // time a late reply has arrived (non-blocking: recv MSG_DONTWAIT on TCP,
  // tcflush on RTU).
  if (r.outcome == LinkOutcome::timeout || r.outcome == LinkOutcome::crc_error ||
      r.outcome == LinkOutcome::bad_frame) {
    modbus_flush(ctx_);
    flush_before_next_ = true;
  }
  return r;
}

LinkResult ModbusLink::write_and_read(std::uint16_t write_address, std::span<const std::uint16_t> values,
                                      std::uint16_t read_address, std::span<std::uint16_t> out) noexcept {
  if (!ready()) return {LinkOutcome::closed, function_code::write_and_read_registers, 0, EBADF};
  const int rc =
      modbus_write_and_read_registers(ctx_, write_address, static_cast<int>(values.size()), values.data(),
                                      read_address, static_cast<int>(out.size()), out.data());
  return finish(rc, function_code::write_and_read_registers);
}

LinkResult ModbusLink::write_registers(std::uint16_t address,
                                       std::span<const std::uint16_t> values) noexcept {
  if (!ready()) return {LinkOutcome::closed, function_code::write_multiple_registers, 0, EBADF};
  const int rc = modbus_write_registers(ctx_, address, static_cast<int>(values.size()), values.data());
  return finish(rc, function_code::write_multiple_registers);
}

LinkResult ModbusLink::read_registers(ReadTable table, std::uint16_t address,
                                      std::span<std::uint16_t> out) noexcept {
  const std::uint8_t fc = table == ReadTable::holding ? function_code::read_holding_registers
                                                      : function_code::read_input_registers;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  const int n = static_cast<int>(out.size());
  const int rc = table == ReadTable::holding ? modbus_read_registers(ctx_, address, n, out.data())
                                             : modbus_read_input_registers(ctx_, address, n, out.data());
  return finish(rc, fc);
}

LinkResult ModbusLink::write_register(std::uint16_t address, std::uint16_t value) noexcept {
  if (!ready()) return {LinkOutcome::closed, function_code::write_single_register, 0, EBADF};
  return finish(modbus_write_register(ctx_, address, value), function_code::write_single_register);
}

LinkResult ModbusLink::write_coil(std::uint16_t address, bool on) noexcept {
  if (!ready()) return {LinkOutcome::closed, function_code::write_single_coil, 0, EBADF};
  return finish(modbus_write_bit(ctx_, address, on ? 1 : 0), function_code::write_single_coil);
}

}  // namespace hapticd::drivers::modbus
