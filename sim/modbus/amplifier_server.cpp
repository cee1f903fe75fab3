#include "sim/modbus/amplifier_server.hpp"

#include <arpa/inet.h>
#include <modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <pty.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <stdexcept>

namespace hapticd::drivers::modbus::sim {

namespace {

// How often the loop wakes without traffic: the watchdog's resolution and
// the stop latency.
constexpr std::uint32_t idle_wake_us = 2000;

}  // namespace

AmplifierServer::AmplifierServer(Amplifier& amplifier, bool rtu)
    : amplifier_(amplifier),
      rtu_(rtu),
      holding_(amplifier.settings().register_count),
      input_(amplifier.settings().register_count),
      coils_(amplifier.settings().coil_count) {
  amplifier_.bind(holding_, input_, coils_);
}

double AmplifierServer::now_s() const noexcept {
  if (clock_ != nullptr) return clock_->now_s();
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::unique_ptr<AmplifierServer> AmplifierServer::tcp(Amplifier& amplifier, const std::string& host,
                                                      int port) {
  std::unique_ptr<AmplifierServer> server(new AmplifierServer(amplifier, false));
  server->ctx_ = modbus_new_tcp(host.c_str(), port);
  if (!server->ctx_) throw std::runtime_error("modbus_new_tcp " + host + ": " + modbus_strerror(errno));
  server->listen_fd_ = modbus_tcp_listen(server->ctx_, 1);
  if (server->listen_fd_ < 0)
    throw std::runtime_error("listen on " + host + ":" + std::to_string(port) + ": " +
                             modbus_strerror(errno));
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (getsockname(server->listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
    throw std::runtime_error(std::string("getsockname: ") + modbus_strerror(errno));
  server->port_ = ntohs(addr.sin_port);
  modbus_set_slave(server->ctx_, amplifier.settings().slave_id);
  return server;
}

std::unique_ptr<AmplifierServer> AmplifierServer::rtu_pty(Amplifier& amplifier) {
  std::unique_ptr<AmplifierServer> server(new AmplifierServer(amplifier, true));
  std::array<char, 128> name{};
  if (openpty(&server->master_fd_, &server->slave_fd_, name.data(), nullptr, nullptr) != 0)
    throw std::runtime_error(std::string("openpty: ") + modbus_strerror(errno));
  server->slave_path_ = name.data();
  // Raw from the start: no echo, no CR/NL translation, before the driver
  // opens the slave and libmodbus sets its own raw termios.
  termios raw{};
  tcgetattr(server->slave_fd_, &raw);
  cfmakeraw(&raw);
  tcsetattr(server->slave_fd_, TCSANOW, &raw);
  // The RTU context never opens a device: it is given the master side.
  server->ctx_ = modbus_new_rtu(server->slave_path_.c_str(), 115200, 'E', 8, 1);
  if (!server->ctx_) throw std::runtime_error(std::string("modbus_new_rtu: ") + modbus_strerror(errno));
  modbus_set_socket(server->ctx_, server->master_fd_);
  modbus_set_slave(server->ctx_, amplifier.settings().slave_id);
  server->client_ = true;
  return server;
}

AmplifierServer::~AmplifierServer() {
  stop();
  if (ctx_) {
    if (rtu_)
      modbus_set_socket(ctx_, -1);  // the fds are closed below, not by libmodbus
    else
      modbus_close(ctx_);
    modbus_free(ctx_);
  }
  if (listen_fd_ >= 0) ::close(listen_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
}

void AmplifierServer::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  modbus_set_indication_timeout(ctx_, 0, idle_wake_us);
  thread_ = std::thread([this] { run(); });
}

int AmplifierServer::make_realtime(int priority) noexcept {
  if (!thread_.joinable()) return ESRCH;
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &p);
}

void AmplifierServer::stop() noexcept {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void AmplifierServer::inject(Injection what, int count, std::uint8_t exception_code, int delay_ms) {
  if (what == Injection::crc_error && !rtu_)
    throw std::invalid_argument("a CRC error needs RTU: Modbus TCP frames carry no CRC");
  amplifier_.inject(what, count, exception_code, delay_ms);
}

bool AmplifierServer::accept_client() noexcept {
  pollfd p{listen_fd_, POLLIN, 0};
  if (poll(&p, 1, static_cast<int>(idle_wake_us / 1000)) <= 0) return false;
  const int client = modbus_tcp_accept(ctx_, &listen_fd_);
  if (client < 0) return false;
  // Reply at once: with Nagle's algorithm a reply waits for the ACK of the
  // previous one, which the client delays until its next request, and every
  // reply then arrives one transaction late.
  const int on = 1;
  setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  connections_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

void AmplifierServer::send_reply(std::span<const std::uint8_t> adu, std::span<const std::uint8_t> pdu,
                                 bool corrupt_crc) noexcept {
  std::array<std::uint8_t, max_reply_bytes> frame{};
  if (rtu_) {
    if (adu[0] == 0) return;  // SL 2.1: no reply to a broadcast
    const std::size_t n = frame_rtu_reply(adu[0], pdu, corrupt_crc, frame);
    [[maybe_unused]] const ssize_t w = ::write(master_fd_, frame.data(), n);
  } else {
    const std::size_t n = frame_tcp_reply(adu, pdu, frame);
    [[maybe_unused]] const ssize_t w = ::send(modbus_get_socket(ctx_), frame.data(), n, MSG_NOSIGNAL);
  }
  replies_.fetch_add(1, std::memory_order_release);
}

int AmplifierServer::line_bytes_waiting() const noexcept {
  if (!rtu_) return -1;
  int waiting = 0;
  return ::ioctl(slave_fd_, TIOCINQ, &waiting) == 0 ? waiting : -1;
}

void AmplifierServer::serve_one(std::span<const std::uint8_t> adu) noexcept {
  // modbus_receive framed one request: TCP the MBAP header (7 bytes), RTU
  // the address and, at the end, the CRC it checked.
  const auto header = static_cast<std::size_t>(modbus_get_header_length(ctx_));
  const std::size_t checksum = rtu_ ? 2 : 0;
  if (adu.size() <= header + checksum) return;
  const std::span<const std::uint8_t> pdu = adu.subspan(header, adu.size() - header - checksum);
  const Decision d = amplifier_.on_request(pdu, now_s());
  if (d.delay_ms > 0) usleep(static_cast<useconds_t>(d.delay_ms) * 1000u);
  std::array<std::uint8_t, max_pdu_bytes> reply{};
  std::size_t n = 0;
  switch (d.kind) {
    case Decision::Kind::reply:
    case Decision::Kind::corrupt_crc:
      n = amplifier_.build_reply(pdu, reply);
      if (n == 0) n = encode_exception_reply(pdu[0], exception::server_device_failure, reply);
      send_reply(adu, std::span<const std::uint8_t>(reply.data(), n), d.kind == Decision::Kind::corrupt_crc);
      break;
    case Decision::Kind::exception:
      n = encode_exception_reply(pdu[0], d.exception_code, reply);
      send_reply(adu, std::span<const std::uint8_t>(reply.data(), n), false);
      break;
    case Decision::Kind::silence:
      break;
    case Decision::Kind::drop:
      modbus_close(ctx_);  // TCP: shutdown + close of the client socket
      client_ = false;
      break;
  }
}

void AmplifierServer::run() noexcept {
  std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> query{};
  while (!stop_.load(std::memory_order_relaxed)) {
    amplifier_.tick(now_s());
    if (!client_) {
      client_ = accept_client();
      continue;
    }
    const int rc = modbus_receive(ctx_, query.data());
    if (rc > 0) {
      serve_one(std::span<const std::uint8_t>(query.data(), static_cast<std::size_t>(rc)));
    } else if (rc < 0 && errno != ETIMEDOUT) {
      if (rtu_) {
        // A garbled frame or a device glitch: drop what is buffered, go on.
        modbus_flush(ctx_);
        usleep(idle_wake_us);
      } else {
        modbus_close(ctx_);  // the client went away: wait for the next one
        client_ = false;
      }
    }
  }
}

}  // namespace hapticd::drivers::modbus::sim
