#include "drivers/modbus/modbus_link.hpp"

#include <modbus.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>

#include <algorithm>
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

double monotonic_s() noexcept {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

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
  if (settings_.transport == Transport::tcp) {
    // Receive times for last_round_trip_s(); without them it falls back.
    const int on = 1;
    (void)setsockopt(modbus_get_socket(ctx_), SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
  }
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
  received_size_ = 0;
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
  // RTU frames carry no transaction id: whatever arrived since the last
  // transaction (a late reply) must not be read as this request's reply.
  // tcflush, non-blocking. Over TCP the transaction id pairs the reply.
  if (settings_.transport == Transport::rtu) modbus_flush(ctx_);
  return true;
}

LinkResult ModbusLink::fail(LinkOutcome outcome, std::uint8_t function, int error_number,
                            std::uint8_t exception_code) noexcept {
  LinkResult r;
  r.outcome = outcome;
  r.function = function;
  r.error_number = error_number;
  r.exception_code = exception_code;
  auto bump = [](std::atomic<std::uint64_t>& c) { c.fetch_add(1, std::memory_order_relaxed); };
  switch (outcome) {
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
  return r;
}

LinkResult ModbusLink::finish(int rc, std::uint8_t function, double started) noexcept {
  counters_.requests.fetch_add(1, std::memory_order_relaxed);
  if (rc >= 0) {
    counters_.responses.fetch_add(1, std::memory_order_relaxed);
    last_round_trip_s_ = monotonic_s() - started;
    LinkResult r;
    r.function = function;
    return r;
  }
  const int e = errno;
  std::uint8_t code = 0;
  const LinkOutcome outcome = classify_error(e, code);
  return fail(outcome, function, e, code);
}

// ---- TCP: the transaction framed by the codec ----

namespace {

double realtime_s() noexcept {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

// recv() that also returns the kernel's receive time of the data (0: none).
ssize_t receive_stamped(int fd, std::uint8_t* data, std::size_t size, double& stamp_s) noexcept {
  iovec io{data, size};
  alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(timespec))> control{};
  msghdr m{};
  m.msg_iov = &io;
  m.msg_iovlen = 1;
  m.msg_control = control.data();
  m.msg_controllen = control.size();
  const ssize_t got = ::recvmsg(fd, &m, MSG_DONTWAIT);
  stamp_s = 0.0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&m); got > 0 && c != nullptr; c = CMSG_NXTHDR(&m, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec t{};
      std::memcpy(&t, CMSG_DATA(c), sizeof t);
      stamp_s = static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
    }
  }
  return got;
}

LinkOutcome socket_outcome(int error_number) noexcept {
  std::uint8_t unused = 0;
  return classify_error(error_number, unused);
}

}  // namespace

void ModbusLink::drop_received() noexcept {
  received_size_ = 0;
  modbus_flush(ctx_);  // recv(MSG_DONTWAIT) until empty
}

LinkResult ModbusLink::tcp_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function) noexcept {
  std::array<std::uint8_t, limits::max_tcp_adu> request{};
  transaction_ = static_cast<std::uint16_t>(transaction_ + 1);
  const std::size_t size =
      build_tcp_adu(request, transaction_, static_cast<std::uint8_t>(settings_.slave_id), pdu);
  const int fd = modbus_get_socket(ctx_);
  counters_.requests.fetch_add(1, std::memory_order_relaxed);
  const double sent_at = realtime_s();
  const double started = monotonic_s();
  double received_at = 0.0;
  // A request is a few dozen bytes on a socket whose send buffer holds
  // megabytes: it leaves whole or the connection is dead.
  const ssize_t sent = ::send(fd, request.data(), size, MSG_NOSIGNAL | MSG_DONTWAIT);
  if (sent < 0) {
    const int e = errno;
    return fail(socket_outcome(e), function, e);
  }
  if (static_cast<std::size_t>(sent) != size) return fail(LinkOutcome::io_error, function, EAGAIN);

  const double deadline = started + settings_.response_timeout_s;
  for (;;) {
    // Every complete ADU buffered: this request's reply, or a late one.
    for (;;) {
      bool invalid = false;
      const std::span<const std::uint8_t> stream(received_.data(), received_size_);
      const std::size_t length = tcp_adu_length(stream, invalid);
      if (invalid) {
        drop_received();
        return fail(LinkOutcome::bad_frame, function, EMBBADDATA);
      }
      if (length == 0) break;
      const Adu adu = parse_tcp_adu(stream.first(length));
      const bool ours = adu.status == AduStatus::ok && adu.transaction == transaction_;
      if (ours) {
        reply_size_ = adu.pdu.size();
        std::copy(adu.pdu.begin(), adu.pdu.end(), reply_.begin());
      } else {
        counters_.late_replies.fetch_add(1, std::memory_order_relaxed);
      }
      std::copy(received_.begin() + static_cast<std::ptrdiff_t>(length),
                received_.begin() + static_cast<std::ptrdiff_t>(received_size_), received_.begin());
      received_size_ -= length;
      if (ours) {
        const double measured = monotonic_s() - started;
        const double stamped = received_at - sent_at;
        // poll() reports data that came after its timeout if this thread
        // ran late: the kernel's receive time says whether it was in time.
        if (stamped > settings_.response_timeout_s) {
          counters_.late_replies.fetch_add(1, std::memory_order_relaxed);
          return fail(LinkOutcome::timeout, function, ETIMEDOUT);
        }
        counters_.responses.fetch_add(1, std::memory_order_relaxed);
        last_round_trip_s_ = stamped > 0.0 && stamped <= measured ? stamped : measured;
        LinkResult r;
        r.function = function;
        return r;
      }
    }
    const double left = deadline - monotonic_s();
    if (left <= 0.0) return fail(LinkOutcome::timeout, function, ETIMEDOUT);
    const auto ns = static_cast<long>(left * 1e9);
    const timespec wait{ns / 1000000000L, ns % 1000000000L};
    pollfd p{fd, POLLIN, 0};
    const int ready = ppoll(&p, 1, &wait, nullptr);
    if (ready < 0 && errno != EINTR) {
      const int e = errno;
      return fail(socket_outcome(e), function, e);
    }
    if (ready <= 0) continue;
    const ssize_t got = receive_stamped(fd, received_.data() + received_size_,
                                        received_.size() - received_size_, received_at);
    if (got == 0) return fail(LinkOutcome::closed, function, ECONNRESET);
    if (got < 0) {
      const int e = errno;
      if (e == EAGAIN || e == EINTR) continue;
      return fail(socket_outcome(e), function, e);
    }
    received_size_ += static_cast<std::size_t>(got);
  }
}

LinkResult ModbusLink::tcp_outcome(PduStatus status, std::uint8_t function,
                                   std::uint8_t exception_code) noexcept {
  switch (status) {
    case PduStatus::ok: {
      LinkResult r;
      r.function = function;
      return r;
    }
    case PduStatus::exception: {
      // Counted once as a response by tcp_exchange: take it back from there.
      counters_.responses.fetch_sub(1, std::memory_order_relaxed);
      if (exception_code == 0 || exception_code >= MODBUS_EXCEPTION_MAX)
        return fail(LinkOutcome::bad_frame, function, EMBBADEXC);
      return fail(LinkOutcome::exception, function, static_cast<int>(MODBUS_ENOBASE + exception_code),
                  exception_code);
    }
    default:
      counters_.responses.fetch_sub(1, std::memory_order_relaxed);
      return fail(LinkOutcome::bad_frame, function, EMBBADDATA);
  }
}

// ---- the transactions ----

LinkResult ModbusLink::write_and_read(std::uint16_t write_address, std::span<const std::uint16_t> values,
                                      std::uint16_t read_address, std::span<std::uint16_t> out) noexcept {
  constexpr std::uint8_t fc = function_code::write_and_read_registers;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (settings_.transport == Transport::tcp) {
    std::array<std::uint8_t, limits::max_pdu> pdu{};
    const std::size_t n = build_write_and_read_request(
        pdu, read_address, static_cast<std::uint16_t>(out.size()), write_address, values);
    if (n == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r = tcp_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status = parse_read_response(reply_pdu(), fc, out, code);
    return tcp_outcome(status, fc, code);
  }
  const double started = monotonic_s();
  const int rc =
      modbus_write_and_read_registers(ctx_, write_address, static_cast<int>(values.size()), values.data(),
                                      read_address, static_cast<int>(out.size()), out.data());
  return finish(rc, fc, started);
}

LinkResult ModbusLink::write_registers(std::uint16_t address,
                                       std::span<const std::uint16_t> values) noexcept {
  constexpr std::uint8_t fc = function_code::write_multiple_registers;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (settings_.transport == Transport::tcp) {
    std::array<std::uint8_t, limits::max_pdu> pdu{};
    const std::size_t n = build_write_multiple_request(pdu, address, values);
    if (n == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r = tcp_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status =
        parse_write_multiple_response(reply_pdu(), address, static_cast<std::uint16_t>(values.size()), code);
    return tcp_outcome(status, fc, code);
  }
  const double started = monotonic_s();
  const int rc = modbus_write_registers(ctx_, address, static_cast<int>(values.size()), values.data());
  return finish(rc, fc, started);
}

LinkResult ModbusLink::read_registers(ReadTable table, std::uint16_t address,
                                      std::span<std::uint16_t> out) noexcept {
  const std::uint8_t fc = table == ReadTable::holding ? function_code::read_holding_registers
                                                      : function_code::read_input_registers;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  const int n = static_cast<int>(out.size());
  if (settings_.transport == Transport::tcp) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t size = build_read_registers_request(pdu, fc, address, static_cast<std::uint16_t>(n));
    if (size == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r = tcp_exchange(std::span<const std::uint8_t>(pdu.data(), size), fc);
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status = parse_read_response(reply_pdu(), fc, out, code);
    return tcp_outcome(status, fc, code);
  }
  const double started = monotonic_s();
  const int rc = table == ReadTable::holding ? modbus_read_registers(ctx_, address, n, out.data())
                                             : modbus_read_input_registers(ctx_, address, n, out.data());
  return finish(rc, fc, started);
}

// fc 5 and 6 over TCP: the reply echoes the request (V1.1b3 6.5, 6.6).
LinkResult ModbusLink::tcp_echo_exchange(std::span<const std::uint8_t> pdu, std::uint8_t fc) noexcept {
  const LinkResult r = tcp_exchange(pdu, fc);
  if (!r.ok()) return r;
  std::uint8_t code = 0;
  return tcp_outcome(parse_echo_response(reply_pdu(), pdu, code), fc, code);
}

LinkResult ModbusLink::write_register(std::uint16_t address, std::uint16_t value) noexcept {
  constexpr std::uint8_t fc = function_code::write_single_register;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (settings_.transport == Transport::tcp) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t n = build_write_single_register_request(pdu, address, value);
    return tcp_echo_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
  }
  const double started = monotonic_s();
  return finish(modbus_write_register(ctx_, address, value), fc, started);
}

LinkResult ModbusLink::write_coil(std::uint16_t address, bool on) noexcept {
  constexpr std::uint8_t fc = function_code::write_single_coil;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (settings_.transport == Transport::tcp) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t n = build_write_single_coil_request(pdu, address, on);
    return tcp_echo_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
  }
  const double started = monotonic_s();
  return finish(modbus_write_bit(ctx_, address, on ? 1 : 0), fc, started);
}

}  // namespace hapticd::drivers::modbus
