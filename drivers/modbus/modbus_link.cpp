#include "drivers/modbus/modbus_link.hpp"

#include <fcntl.h>
#include <modbus.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/ip.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
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

std::string timeout_text(double s) {
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
    case LinkOutcome::stopped:
      return "stopped";
  }
  return "?";
}

namespace {

std::string frame_problem_text(const LinkResult& r) {
  char text[160];
  switch (r.problem) {
    case FrameProblem::wrong_unit:
      std::snprintf(text, sizeof text, "from unit %u, not the unit %u it was sent to", unsigned{r.got},
                    unsigned{r.expected});
      return text;
    case FrameProblem::protocol_id:
      std::snprintf(text, sizeof text, "MBAP protocol id 0x%04X, not 0 (Modbus)", unsigned{r.got});
      return text;
    case FrameProblem::length:
      std::snprintf(text, sizeof text, "MBAP length %u, where the reply has %u (an exception 3)",
                    unsigned{r.got}, unsigned{r.expected});
      return text;
    case FrameProblem::none:
      break;
  }
  return modbus_strerror(r.error_number);
}

}  // namespace

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
      return "malformed reply" + to + " (" + frame_problem_text(r) + ")";
    case LinkOutcome::closed:
      return "connection closed (" + system_error(r.error_number) + ")";
    case LinkOutcome::io_error:
      return "I/O error (" + system_error(r.error_number) + ")";
    case LinkOutcome::stopped:
      return "abandoned, hapticd is stopping (function " + std::string(fc) + ")";
  }
  return "?";
}

ModbusLink::ModbusLink(LinkSettings settings) : settings_(std::move(settings)) {
  if (settings_.transport == Transport::tcp) {
    const std::string service = std::to_string(settings_.port);
    ctx_ = modbus_new_tcp_pi(settings_.host.c_str(), service.c_str());
    if (!ctx_)
      throw DeviceError(
          "modbus: cannot make a Modbus TCP context for " + settings_.host + ": " + system_error(errno),
          "host");
  } else {
    ctx_ = modbus_new_rtu(settings_.device.c_str(), settings_.serial.baud,
                          parity_letter(settings_.serial.parity), settings_.serial.data_bits,
                          settings_.serial.stop_bits);
    if (!ctx_)
      throw DeviceError(
          "modbus: cannot make a Modbus RTU context for " + settings_.device + ": " + system_error(errno),
          "device");
  }
  // Recovery would sleep a whole response timeout and reconnect inside a
  // transaction, on the RT thread; the device decides instead.
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_NONE);
  if (modbus_set_slave(ctx_, settings_.slave_id) != 0)
    throw DeviceError("modbus: libmodbus refuses slave id " + std::to_string(settings_.slave_id) + ": " +
                          system_error(errno),
                      "slave_id");
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
    throw DeviceError("modbus: libmodbus refuses a response timeout of " +
                          std::to_string(settings_.response_timeout_s) + " s: " + system_error(errno),
                      "response_timeout");
  const TimeoutParts byte = split_seconds(settings_.byte_timeout_s);
  if (modbus_set_byte_timeout(ctx_, byte.sec, byte.usec) != 0)
    throw DeviceError("modbus: libmodbus refuses a byte timeout of " +
                          std::to_string(settings_.byte_timeout_s) + " s: " + system_error(errno),
                      "byte_timeout");
}

void ModbusLink::set_response_timeout(double seconds) {
  settings_.response_timeout_s = seconds;
  apply_timeouts();
}

void ModbusLink::open() {
  if (open_) return;
  if (settings_.transport == Transport::tcp) {
    connect_tcp();
  } else if (modbus_connect(ctx_) != 0) {  // RTU: open(2) and termios, no wait
    const int e = errno;
    throw DeviceError("modbus: cannot open serial device " + settings_.device + ": " + system_error(e),
                      "device");
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
    throw DeviceError("modbus: " + settings_.device + " refuses RS-485 mode (TIOCSRS485: " + system_error(e) +
                          "): its kernel driver cannot switch the transceiver; use an adapter that "
                          "switches direction by itself and set rs485 = false",
                      "rs485");
  }
  try {
    apply_timeouts();
  } catch (...) {
    close();
    throw;
  }
}

namespace {

/// A connect() in flight on a non-blocking socket, waited for in slices.
/// 0 when connected, else the errno; ETIMEDOUT when `wait` expired.
int wait_connected(int fd, const SlicedWait& wait) {
  for (;;) {
    if (wait.expired()) return ETIMEDOUT;
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait.next_slice()).count();
    const timespec slice{static_cast<time_t>(ns / 1000000000L), static_cast<long>(ns % 1000000000L)};
    pollfd p{fd, POLLOUT, 0};
    const int ready = ppoll(&p, 1, &slice, nullptr);
    if (ready < 0 && errno != EINTR) return errno;
    if (ready > 0) {
      int error = 0;
      socklen_t size = sizeof error;
      if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size) != 0) return errno;
      return error;
    }
    if (wait.stopped()) return ECANCELED;
  }
}

}  // namespace

// libmodbus 3.1.6 waits for a TCP connect() in one select() of the whole
// timeout; this is its connect (non-blocking socket, TCP_NODELAY, low-delay
// TOS) with the wait in slices, and the socket handed to the context.
void ModbusLink::connect_tcp() {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(settings_.port);
  if (const int e = getaddrinfo(settings_.host.c_str(), service.c_str(), &hints, &found); e != 0)
    throw DeviceError("modbus: cannot resolve Modbus TCP host " + settings_.host + ": " + gai_strerror(e),
                      "host");
  const auto timeout = std::chrono::duration_cast<SlicedWait::Clock::duration>(
      std::chrono::duration<double>(settings_.connect_timeout_s));
  const SlicedWait wait(stop_, timeout);
  int fd = -1, error = ETIMEDOUT;
  for (const addrinfo* a = found; a != nullptr && fd < 0 && error != ECANCELED; a = a->ai_next) {
    fd = ::socket(a->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) {
      error = errno;
      continue;
    }
    const int on = 1, tos = IPTOS_LOWDELAY;
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    if (a->ai_family == AF_INET) (void)setsockopt(fd, IPPROTO_IP, IP_TOS, &tos, sizeof tos);
    error = ::connect(fd, a->ai_addr, a->ai_addrlen) == 0 ? 0 : errno;
    if (error == EINPROGRESS) error = wait_connected(fd, wait);
    if (error != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  freeaddrinfo(found);
  if (error == ECANCELED)
    throw StopRequested(abandoned("modbus: connecting to Modbus TCP " + settings_.host + ":" + service));
  if (fd < 0)
    throw DeviceError("modbus: cannot connect to Modbus TCP " + settings_.host + ":" + service + " within " +
                          timeout_text(settings_.connect_timeout_s) + ": " + system_error(error),
                      "host");
  modbus_set_socket(ctx_, fd);
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
    case LinkOutcome::stopped:
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

namespace {

std::uint16_t get16(const std::uint8_t* p) noexcept { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }

/// The time left to `deadline` (monotonic s) as a ppoll() timeout, at most one stop slice.
timespec slice_until(double deadline) noexcept {
  const double slice = std::chrono::duration<double>(stop_slice).count();
  const double left = std::clamp(deadline - monotonic_s(), 0.0, slice);
  const auto ns = static_cast<long>(left * 1e9);
  return {ns / 1000000000L, ns % 1000000000L};
}

}  // namespace

bool ModbusLink::framed_here() const noexcept {
  return settings_.transport == Transport::tcp ||
         settings_.response_timeout_s > std::chrono::duration<double>(stop_slice).count();
}

LinkResult ModbusLink::framed_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                                       std::size_t reply_size) noexcept {
  return settings_.transport == Transport::tcp ? tcp_exchange(pdu, function, reply_size)
                                               : rtu_exchange(pdu, function, reply_size);
}

LinkResult ModbusLink::frame_problem(FrameProblem problem, std::uint8_t function, std::uint16_t got,
                                     std::uint16_t expected) noexcept {
  LinkResult r =
      fail(LinkOutcome::bad_frame, function, problem == FrameProblem::wrong_unit ? EMBBADSLAVE : EMBBADDATA);
  r.problem = problem;
  r.got = got;
  r.expected = expected;
  return r;
}

// Frames every complete ADU buffered: this request's reply (true), a late
// one or one from another unit (dropped, counted), or a header that puts
// the stream out of step (true, `failure` says why; the buffer is dropped).
bool ModbusLink::take_tcp_reply(std::uint8_t function, std::size_t reply_size, LinkResult& failure,
                                int& wrong_unit) noexcept {
  for (;;) {
    const std::span<const std::uint8_t> stream(received_.data(), received_size_);
    if (stream.size() < 7) return false;
    const std::uint16_t protocol = get16(&stream[2]), length = get16(&stream[4]);
    const bool ours = get16(&stream[0]) == transaction_;
    // TCP 3.1.3: the length counts the unit id and the PDU; this request's
    // reply has the normal reply's or an exception's (AP 7: 2-byte PDU).
    const bool fits = !ours || length == mbap_length(reply_size) || length == mbap_length(2);
    bool invalid = false;
    const std::size_t size = tcp_adu_length(stream, invalid);
    if (invalid || !fits) {
      drop_received();
      failure = protocol != 0
                    ? frame_problem(FrameProblem::protocol_id, function, protocol, 0)
                    : frame_problem(FrameProblem::length, function, length, mbap_length(reply_size));
      return true;
    }
    if (size == 0) return false;  // the rest is still on its way
    // The length must be the one of what the PDU is: an exception (AP 7:
    // function | 0x80, code) or the normal reply.
    const bool exception = (stream[7] & function_code::exception_flag) != 0;
    if (ours && length != (exception ? mbap_length(2) : mbap_length(reply_size))) {
      drop_received();
      failure = frame_problem(FrameProblem::length, function, length, mbap_length(reply_size));
      return true;
    }
    const Adu adu = parse_tcp_adu(stream.first(size));
    const bool from_unit = adu.unit == settings_.slave_id;
    const bool mine = ours && from_unit && adu.status == AduStatus::ok;
    if (mine) {
      reply_size_ = adu.pdu.size();
      std::copy(adu.pdu.begin(), adu.pdu.end(), reply_.begin());
    } else if (ours && !from_unit) {
      counters_.wrong_unit.fetch_add(1, std::memory_order_relaxed);
      wrong_unit = adu.unit;
    } else {
      counters_.late_replies.fetch_add(1, std::memory_order_relaxed);
    }
    std::copy(received_.begin() + static_cast<std::ptrdiff_t>(size),
              received_.begin() + static_cast<std::ptrdiff_t>(received_size_), received_.begin());
    received_size_ -= size;
    if (mine) return true;
  }
}

LinkResult ModbusLink::tcp_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                                    std::size_t reply_size) noexcept {
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
  int wrong_unit = -1;  // the unit id of a reply dropped for it
  for (;;) {
    LinkResult failure;
    if (take_tcp_reply(function, reply_size, failure, wrong_unit)) {
      if (!failure.ok()) return failure;
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
    if (monotonic_s() >= deadline) {
      if (wrong_unit >= 0)
        return frame_problem(FrameProblem::wrong_unit, function, static_cast<std::uint16_t>(wrong_unit),
                             static_cast<std::uint16_t>(settings_.slave_id));
      return fail(LinkOutcome::timeout, function, ETIMEDOUT);
    }
    const timespec wait = slice_until(deadline);
    pollfd p{fd, POLLIN, 0};
    const int ready = ppoll(&p, 1, &wait, nullptr);
    if (ready < 0 && errno != EINTR) {
      const int e = errno;
      return fail(socket_outcome(e), function, e);
    }
    // Only a wait longer than a slice (off the loop) ever gets here with time left.
    if (ready == 0 && monotonic_s() < deadline && stop_.stop_requested())
      return fail(LinkOutcome::stopped, function, ECANCELED);
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

// RTU with a long response timeout (off the loop): libmodbus frames and
// sends the request (RTU CRC, its serial settings) but would wait for the
// reply in one select() of the whole timeout; the reply is read here in
// slices, framed by the request (SL 2.5.1: address, PDU, CRC; an exception
// is address, function | 0x80, code, CRC) and checked by the codec.
LinkResult ModbusLink::rtu_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                                    std::size_t reply_size) noexcept {
  std::array<std::uint8_t, limits::max_pdu + 1> raw{};
  raw[0] = static_cast<std::uint8_t>(settings_.slave_id);
  std::copy(pdu.begin(), pdu.end(), raw.begin() + 1);
  counters_.requests.fetch_add(1, std::memory_order_relaxed);
  const double started = monotonic_s();
  if (modbus_send_raw_request(ctx_, raw.data(), static_cast<int>(pdu.size() + 1)) < 0) {
    const int e = errno;
    return fail(socket_outcome(e), function, e);
  }
  const int fd = modbus_get_socket(ctx_);
  const double deadline = started + settings_.response_timeout_s;
  std::size_t need = reply_size + 3, have = 0;
  received_size_ = 0;
  for (;;) {
    if (have >= 2 && received_[1] == (function | function_code::exception_flag)) need = 5;
    if (have >= need) break;
    if (monotonic_s() >= deadline) return fail(LinkOutcome::timeout, function, ETIMEDOUT);
    const timespec wait = slice_until(deadline);
    pollfd p{fd, POLLIN, 0};
    const int ready = ppoll(&p, 1, &wait, nullptr);
    if (ready < 0 && errno != EINTR) {
      const int e = errno;
      return fail(socket_outcome(e), function, e);
    }
    if (ready == 0 && monotonic_s() < deadline && stop_.stop_requested())
      return fail(LinkOutcome::stopped, function, ECANCELED);
    if (ready <= 0) continue;
    const ssize_t got = ::read(fd, received_.data() + have, need - have);
    if (got == 0) return fail(LinkOutcome::closed, function, EIO);
    if (got < 0) {
      const int e = errno;
      if (e == EAGAIN || e == EINTR) continue;
      return fail(socket_outcome(e), function, e);
    }
    have += static_cast<std::size_t>(got);
  }
  const Adu adu = parse_rtu_adu(std::span<const std::uint8_t>(received_.data(), need));
  if (adu.status != AduStatus::ok) return fail(LinkOutcome::crc_error, function, EMBBADCRC);
  if (adu.unit != settings_.slave_id) {
    counters_.wrong_unit.fetch_add(1, std::memory_order_relaxed);
    return frame_problem(FrameProblem::wrong_unit, function, adu.unit,
                         static_cast<std::uint16_t>(settings_.slave_id));
  }
  reply_size_ = adu.pdu.size();
  std::copy(adu.pdu.begin(), adu.pdu.end(), reply_.begin());
  counters_.responses.fetch_add(1, std::memory_order_relaxed);
  last_round_trip_s_ = monotonic_s() - started;
  LinkResult r;
  r.function = function;
  return r;
}

LinkResult ModbusLink::pdu_outcome(PduStatus status, std::uint8_t function,
                                   std::uint8_t exception_code) noexcept {
  switch (status) {
    case PduStatus::ok: {
      LinkResult r;
      r.function = function;
      return r;
    }
    case PduStatus::exception: {
      // Counted once as a response by the exchange: take it back from there.
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
  if (framed_here()) {
    std::array<std::uint8_t, limits::max_pdu> pdu{};
    const std::size_t n = build_write_and_read_request(
        pdu, read_address, static_cast<std::uint16_t>(out.size()), write_address, values);
    if (n == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r =
        framed_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc, 2 + 2 * out.size());
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status = parse_read_response(reply_pdu(), fc, out, code);
    return pdu_outcome(status, fc, code);
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
  if (framed_here()) {
    std::array<std::uint8_t, limits::max_pdu> pdu{};
    const std::size_t n = build_write_multiple_request(pdu, address, values);
    if (n == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r = framed_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc, 5);
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status =
        parse_write_multiple_response(reply_pdu(), address, static_cast<std::uint16_t>(values.size()), code);
    return pdu_outcome(status, fc, code);
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
  if (framed_here()) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t size = build_read_registers_request(pdu, fc, address, static_cast<std::uint16_t>(n));
    if (size == 0) return fail(LinkOutcome::io_error, fc, EMBMDATA);
    const LinkResult r =
        framed_exchange(std::span<const std::uint8_t>(pdu.data(), size), fc, 2 + 2 * out.size());
    if (!r.ok()) return r;
    std::uint8_t code = 0;
    const PduStatus status = parse_read_response(reply_pdu(), fc, out, code);
    return pdu_outcome(status, fc, code);
  }
  const double started = monotonic_s();
  const int rc = table == ReadTable::holding ? modbus_read_registers(ctx_, address, n, out.data())
                                             : modbus_read_input_registers(ctx_, address, n, out.data());
  return finish(rc, fc, started);
}

// fc 5 and 6: the reply echoes the request (V1.1b3 6.5, 6.6).
LinkResult ModbusLink::echo_exchange(std::span<const std::uint8_t> pdu, std::uint8_t fc) noexcept {
  const LinkResult r = framed_exchange(pdu, fc, pdu.size());
  if (!r.ok()) return r;
  std::uint8_t code = 0;
  return pdu_outcome(parse_echo_response(reply_pdu(), pdu, code), fc, code);
}

LinkResult ModbusLink::write_register(std::uint16_t address, std::uint16_t value) noexcept {
  constexpr std::uint8_t fc = function_code::write_single_register;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (framed_here()) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t n = build_write_single_register_request(pdu, address, value);
    return echo_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
  }
  const double started = monotonic_s();
  return finish(modbus_write_register(ctx_, address, value), fc, started);
}

LinkResult ModbusLink::write_coil(std::uint16_t address, bool on) noexcept {
  constexpr std::uint8_t fc = function_code::write_single_coil;
  if (!ready()) return {LinkOutcome::closed, fc, 0, EBADF};
  if (framed_here()) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t n = build_write_single_coil_request(pdu, address, on);
    return echo_exchange(std::span<const std::uint8_t>(pdu.data(), n), fc);
  }
  const double started = monotonic_s();
  return finish(modbus_write_bit(ctx_, address, on ? 1 : 0), fc, started);
}

}  // namespace hapticd::drivers::modbus
