// The libmodbus link against the simulated amplifier, over TCP on 127.0.0.1
// and over RTU on a pseudo-terminal pair: transactions, the outcome of each
// injected failure, the frames libmodbus puts on the wire compared byte by
// byte with the codec, and no allocation on the transaction path.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <modbus.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "c_alloc_counter.hpp"
#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_frame.hpp"
#include "drivers/modbus/modbus_link.hpp"
#include "loopback_plant.hpp"
#include "sim/modbus/amplifier_server.hpp"
#include "tests/support/alloc_counter.hpp"

namespace link_test {

namespace mb = hapticd::drivers::modbus;
using mb::LinkOutcome;
using Bytes = std::vector<std::uint8_t>;

namespace {

mb::sim::AmplifierSettings amplifier_settings(const mb::ModbusConfig& c) {
  mb::sim::AmplifierSettings s;
  s.position_per_count = c.position_per_count();
  s.torque_per_count = c.torque_per_count;
  return s;
}

// Generous: a timeout here is only ever an injected one (the VM's vCPU stalls for ms).
constexpr double test_response_timeout_s = 0.5;

class LinkTest : public ::testing::TestWithParam<mb::Transport> {
 protected:
  LinkTest() : config_(mb::modbus_config({})), amplifier_(amplifier_settings(config_), plant_) {
    server_ =
        rtu() ? mb::sim::AmplifierServer::rtu_pty(amplifier_) : mb::sim::AmplifierServer::tcp(amplifier_);
    server_->start();
    (void)server_->make_realtime(70);  // as an amplifier is its own hardware, when permitted
  }
  ~LinkTest() override { server_->stop(); }

  bool rtu() const { return GetParam() == mb::Transport::rtu; }

  mb::LinkSettings settings(double response_timeout_s = test_response_timeout_s) const {
    mb::LinkSettings s;
    s.transport = GetParam();
    s.port = server_->port();
    s.device = server_->slave_path();
    s.response_timeout_s = response_timeout_s;
    return s;
  }

  /// Waits, bounded, until the amplifier has written `replies` replies and,
  /// over RTU, bytes of them wait in the line's receive queue (over TCP a
  /// reply written on loopback is in the client's socket when send() returns).
  bool late_reply_waiting(std::uint64_t replies) const {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    const auto arrived = [&] {
      return server_->replies() >= replies && (!rtu() || server_->line_bytes_waiting() > 0);
    };
    while (!arrived() && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return arrived();
  }

  mb::LinkResult exchange(mb::ModbusLink& link, std::int16_t torque, std::array<std::uint16_t, 6>& state) {
    const std::array<std::uint16_t, 2> command{static_cast<std::uint16_t>(torque), 50};
    return link.write_and_read(10, command, 0, state);
  }

  mb::ModbusConfig config_;
  mb::testing::LoopbackPlant plant_;
  mb::sim::Amplifier amplifier_;
  std::unique_ptr<mb::sim::AmplifierServer> server_;
};

std::string name(const ::testing::TestParamInfo<mb::Transport>& info) {
  return info.param == mb::Transport::tcp ? "Tcp" : "Rtu";
}

}  // namespace

TEST_P(LinkTest, WriteAndReadAppliesTheCommandAndReturnsTheNewState) {
  mb::ModbusLink link(settings());
  link.open();
  ASSERT_TRUE(link.write_register(12, 0x0001).ok());  // enable bit
  std::array<std::uint16_t, 6> state{};
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(exchange(link, 800, state).ok());
  const mb::sim::AmplifierState amp = amplifier_.state();
  EXPECT_TRUE(amp.enabled);
  EXPECT_EQ(amp.steps, 50u);
  EXPECT_DOUBLE_EQ(amp.applied_torque, 0.8);
  // The reply carries the position after the 50th step (fc 23 writes, then reads).
  hapticd::drivers::Reading r;
  plant_.sense(r.position);
  const std::int32_t counts = mb::join_words(state[0], state[1], mb::WordOrder::high_first);
  EXPECT_GT(counts, 0);
  EXPECT_EQ(counts, std::llround(r.position / config_.position_per_count()));
  EXPECT_EQ(state[4] & 0x1u, 0x1u);  // status: enabled
  EXPECT_EQ(link.counters().requests.load(), 51u);
  EXPECT_EQ(link.counters().responses.load(), 51u);
}

TEST_P(LinkTest, AnExceptionReplyCarriesItsCode) {
  mb::ModbusLink link(settings());
  link.open();
  server_->inject(mb::sim::Injection::exception, 1, mb::exception_code::server_device_failure);
  std::array<std::uint16_t, 6> state{};
  const mb::LinkResult r = exchange(link, 100, state);
  EXPECT_EQ(r.outcome, LinkOutcome::exception);
  EXPECT_EQ(r.exception_code, mb::exception_code::server_device_failure);
  EXPECT_EQ(mb::describe(r), "exception 0x04 (server device failure) in reply to function 0x17");
  EXPECT_EQ(link.counters().exceptions.load(), 1u);
  EXPECT_TRUE(exchange(link, 100, state).ok());
}

TEST_P(LinkTest, ALostRequestTimesOutAndTheNextTransactionSucceeds) {
  mb::ModbusLink link(settings(0.05));
  link.open();
  server_->inject(mb::sim::Injection::timeout);
  std::array<std::uint16_t, 6> state{};
  EXPECT_EQ(exchange(link, 100, state).outcome, LinkOutcome::timeout);
  EXPECT_EQ(link.counters().timeouts.load(), 1u);
  link.set_response_timeout(test_response_timeout_s);
  EXPECT_TRUE(exchange(link, 100, state).ok());
  EXPECT_EQ(link.counters().requests.load(), 2u);
  EXPECT_EQ(link.counters().responses.load(), 1u);
}

TEST_P(LinkTest, TransactionsAllocateNothing) {
  mb::ModbusLink link(settings());
  link.open();
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
#ifdef HAPTICD_SANITIZED
  GTEST_SKIP() << "C allocations are counted in the normal build (a sanitizer owns malloc here)";
#endif
  ASSERT_TRUE(mb::testing::c_allocation_counting_active());
  std::array<std::uint16_t, 6> state{};
  std::array<std::uint16_t, 2> command{0, 50};
  server_->inject(mb::sim::Injection::exception, 10, mb::exception_code::server_device_busy);
  std::size_t cpp = 0, c = 0;
  int ok = 0;
  {
    hapticd::testing::AllocationGuard cpp_guard;
    mb::testing::CAllocationGuard c_guard;
    for (int i = 0; i < 200; ++i) {
      ok += link.write_and_read(10, command, 0, state).ok();  // the first ten are exceptions
      ok += link.write_registers(10, command).ok();
      ok += link.read_registers(mb::ReadTable::holding, 0, state).ok();
    }
    cpp = cpp_guard.count();
    c = c_guard.count();
  }
  EXPECT_EQ(cpp, 0u);
  EXPECT_EQ(c, 0u);
  EXPECT_EQ(ok, 600 - 10) << "every transaction answered but the ten exceptions";
  EXPECT_EQ(link.counters().exceptions.load(), 10u);
}

INSTANTIATE_TEST_SUITE_P(ModbusLink, LinkTest, ::testing::Values(mb::Transport::tcp, mb::Transport::rtu),
                         name);

TEST(ModbusLinkRtu, ACrcErrorIsReportedAndTheNextTransactionSucceeds) {
  const mb::ModbusConfig config = mb::modbus_config({});
  mb::testing::LoopbackPlant plant;
  mb::sim::Amplifier amplifier(amplifier_settings(config), plant);
  auto server = mb::sim::AmplifierServer::rtu_pty(amplifier);
  server->start();
  mb::LinkSettings s;
  s.transport = mb::Transport::rtu;
  s.device = server->slave_path();
  s.response_timeout_s = test_response_timeout_s;
  mb::ModbusLink link(s);
  link.open();
  server->inject(mb::sim::Injection::crc_error);
  std::array<std::uint16_t, 6> state{};
  const std::array<std::uint16_t, 2> command{100, 50};
  const mb::LinkResult r = link.write_and_read(10, command, 0, state);
  EXPECT_EQ(r.outcome, LinkOutcome::crc_error);
  EXPECT_EQ(mb::describe(r), "CRC error in reply to function 0x17");
  EXPECT_EQ(link.counters().crc_errors.load(), 1u);
  EXPECT_TRUE(link.write_and_read(10, command, 0, state).ok());
  EXPECT_EQ(amplifier.state().steps, 2u);  // the corrupted reply's request was applied
}

TEST(ModbusLinkRtu, Rs485ModeOnAPseudoTerminalIsRefusedNamingTheKey) {
  const mb::ModbusConfig config = mb::modbus_config({});
  mb::testing::LoopbackPlant plant;
  mb::sim::Amplifier amplifier(amplifier_settings(config), plant);
  auto server = mb::sim::AmplifierServer::rtu_pty(amplifier);
  mb::LinkSettings s;
  s.transport = mb::Transport::rtu;
  s.device = server->slave_path();
  s.rs485 = true;
  mb::ModbusLink link(s);
  try {
    link.open();
    FAIL() << "a pty accepted TIOCSRS485";
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "rs485");
    EXPECT_NE(std::string(e.what()).find("refuses RS-485 mode"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(link.is_open());
}

TEST(ModbusLinkRtu, AMissingDeviceNamesTheDeviceKey) {
  mb::LinkSettings s;
  s.transport = mb::Transport::rtu;
  s.device = "/dev/hapticd-no-such-tty";
  mb::ModbusLink link(s);
  try {
    link.open();
    FAIL();
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "device");
    EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos) << e.what();
  }
}

TEST(ModbusLinkTcp, ADroppedConnectionIsClosedAndReopenRecovers) {
  const mb::ModbusConfig config = mb::modbus_config({});
  mb::testing::LoopbackPlant plant;
  mb::sim::Amplifier amplifier(amplifier_settings(config), plant);
  auto server = mb::sim::AmplifierServer::tcp(amplifier);
  server->start();
  mb::LinkSettings s;
  s.transport = mb::Transport::tcp;
  s.port = server->port();
  s.response_timeout_s = test_response_timeout_s;
  mb::ModbusLink link(s);
  link.open();
  server->inject(mb::sim::Injection::drop);
  std::array<std::uint16_t, 6> state{};
  const std::array<std::uint16_t, 2> command{100, 50};
  const mb::LinkResult r = link.write_and_read(10, command, 0, state);
  EXPECT_EQ(r.outcome, LinkOutcome::closed);
  EXPECT_EQ(mb::describe(r), "connection closed (Connection reset by peer)");
  link.reopen();
  EXPECT_TRUE(link.write_and_read(10, command, 0, state).ok());
  EXPECT_EQ(link.counters().reconnects.load(), 1u);
  EXPECT_EQ(server->connections(), 2u);
}

TEST(ModbusLinkTcp, ARefusedConnectionNamesTheHostKey) {
  // A port nobody listens on: bind one, note it, close it.
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), len), 0);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  close(fd);
  mb::LinkSettings s;
  s.transport = mb::Transport::tcp;
  s.port = ntohs(addr.sin_port);
  mb::ModbusLink link(s);
  try {
    link.open();
    FAIL();
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "host");
    EXPECT_NE(std::string(e.what()).find("Connection refused"), std::string::npos) << e.what();
  }
}

namespace {

// Reads `n` bytes from fd within 2 s (the peer side of a link under test).
Bytes read_bytes(int fd, std::size_t n) {
  Bytes out;
  std::array<std::uint8_t, 512> buffer{};
  while (out.size() < n) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 2000) <= 0) break;
    const ssize_t got = ::read(fd, buffer.data(), std::min(buffer.size(), n - out.size()));
    if (got <= 0) break;
    out.insert(out.end(), buffer.begin(), buffer.begin() + got);
  }
  return out;
}

template <class Build>
Bytes pdu(Build build) {
  std::array<std::uint8_t, 260> buffer{};
  const std::size_t n = build(std::span<std::uint8_t>(buffer));
  return Bytes(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
}

Bytes rtu(std::uint8_t slave, const Bytes& p) {
  std::array<std::uint8_t, 260> buffer{};
  const std::size_t n = mb::build_rtu_adu(buffer, slave, p);
  return Bytes(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
}

Bytes tcp(std::uint16_t transaction, std::uint8_t unit, const Bytes& p) {
  std::array<std::uint8_t, 260> buffer{};
  const std::size_t n = mb::build_tcp_adu(buffer, transaction, unit, p);
  return Bytes(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
}

}  // namespace

// libmodbus is an independent implementation: the requests it sends must be
// the codec's frames, byte for byte (and so the spec's, which the codec is
// tested against).
TEST(ModbusLinkRtu, RequestsOnTheWireMatchTheCodec) {
  int master = -1, slave = -1;
  std::array<char, 128> path{};
  ASSERT_EQ(openpty(&master, &slave, path.data(), nullptr, nullptr), 0);
  mb::LinkSettings s;
  s.transport = mb::Transport::rtu;
  s.device = path.data();
  s.slave_id = 0x11;
  s.response_timeout_s = 0.05;  // nobody answers
  mb::ModbusLink link(s);
  link.open();
  const std::array<std::uint16_t, 3> values{0x00FF, 0x00FF, 0x00FF};
  std::array<std::uint16_t, 6> out{};
  auto sent = [&](auto transaction, std::size_t size) {
    std::thread t(transaction);
    Bytes bytes = read_bytes(master, size);
    t.join();
    return bytes;
  };
  EXPECT_EQ(
      sent([&] { (void)link.write_and_read(0x000E, values, 0x0003, out); }, 19),
      rtu(0x11, pdu([&](auto o) { return mb::build_write_and_read_request(o, 0x0003, 6, 0x000E, values); })));
  EXPECT_EQ(sent([&] { (void)link.write_registers(0x0001, std::span(values).first(2)); }, 13),
            rtu(0x11, pdu([&](auto o) {
                  return mb::build_write_multiple_request(o, 0x0001, std::span(values).first(2));
                })));
  EXPECT_EQ(
      sent([&] { (void)link.read_registers(mb::ReadTable::holding, 0x006B, std::span(out).first(3)); }, 8),
      Bytes({0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87}));  // the published frame
  EXPECT_EQ(
      sent([&] { (void)link.read_registers(mb::ReadTable::input, 0x0008, std::span(out).first(1)); }, 8),
      rtu(0x11, pdu([&](auto o) { return mb::build_read_registers_request(o, 0x04, 0x0008, 1); })));
  EXPECT_EQ(
      sent([&] { (void)link.write_register(0x0001, 0x0003); }, 8),
      rtu(0x11, pdu([&](auto o) { return mb::build_write_single_register_request(o, 0x0001, 0x0003); })));
  EXPECT_EQ(sent([&] { (void)link.write_coil(0x00AC, true); }, 8),
            rtu(0x11, pdu([&](auto o) { return mb::build_write_single_coil_request(o, 0x00AC, true); })));
  link.close();
  close(master);
  close(slave);
}

TEST(ModbusLinkTcp, RequestsOnTheWireMatchTheCodec) {
  const int listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), len), 0);
  ASSERT_EQ(listen(listener, 1), 0);
  ASSERT_EQ(getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  mb::LinkSettings s;
  s.transport = mb::Transport::tcp;
  s.port = ntohs(addr.sin_port);
  s.slave_id = 0x11;
  s.response_timeout_s = 0.05;
  mb::ModbusLink link(s);
  link.open();
  const int peer = accept(listener, nullptr, nullptr);
  ASSERT_GE(peer, 0);
  const std::array<std::uint16_t, 3> values{0x00FF, 0x00FF, 0x00FF};
  std::array<std::uint16_t, 6> out{};
  auto sent = [&](auto transaction, std::size_t size) {
    std::thread t(transaction);
    Bytes bytes = read_bytes(peer, size);
    t.join();
    return bytes;
  };
  // The MBAP transaction identifier counts the requests: 1, 2, ...
  EXPECT_EQ(sent([&] { (void)link.write_and_read(0x000E, values, 0x0003, out); }, 23),
            tcp(1, 0x11,
                pdu([&](auto o) { return mb::build_write_and_read_request(o, 0x0003, 6, 0x000E, values); })));
  EXPECT_EQ(
      sent([&] { (void)link.read_registers(mb::ReadTable::holding, 0x006B, std::span(out).first(3)); }, 12),
      tcp(2, 0x11, pdu([&](auto o) { return mb::build_read_registers_request(o, 0x03, 0x006B, 3); })));
  link.close();
  close(peer);
  close(listener);
}

TEST(ModbusLinkErrors, LibmodbusErrnosMapToOutcomes) {
  std::uint8_t code = 0;
  EXPECT_EQ(mb::classify_error(EMBXILADD, code), LinkOutcome::exception);
  EXPECT_EQ(code, 0x02);
  EXPECT_EQ(mb::classify_error(EMBXGTAR, code), LinkOutcome::exception);
  EXPECT_EQ(code, 0x0B);
  EXPECT_EQ(mb::classify_error(EMBBADCRC, code), LinkOutcome::crc_error);
  EXPECT_EQ(code, 0);
  EXPECT_EQ(mb::classify_error(ETIMEDOUT, code), LinkOutcome::timeout);
  EXPECT_EQ(mb::classify_error(EMBBADSLAVE, code), LinkOutcome::bad_frame);
  EXPECT_EQ(mb::classify_error(EMBBADDATA, code), LinkOutcome::bad_frame);
  EXPECT_EQ(mb::classify_error(ECONNRESET, code), LinkOutcome::closed);
  EXPECT_EQ(mb::classify_error(EPIPE, code), LinkOutcome::closed);
  EXPECT_EQ(mb::classify_error(EIO, code), LinkOutcome::closed);
  EXPECT_EQ(mb::classify_error(ENOMEM, code), LinkOutcome::io_error);
}

// A reply that arrives after its transaction timed out must not be taken
// for the next transaction's (on RTU it would look valid: no transaction id).
TEST_P(LinkTest, ALateReplyIsDroppedBeforeTheNextRequest) {
  mb::ModbusLink link(settings(0.02));
  link.open();
  server_->inject(mb::sim::Injection::late, 1, 0, 300);
  std::array<std::uint16_t, 6> state{};
  EXPECT_EQ(exchange(link, 100, state).outcome, LinkOutcome::timeout);
  ASSERT_TRUE(late_reply_waiting(1)) << "the late reply never came";  // in the buffer now
  ASSERT_TRUE(amplifier_.state().steps == 1u);
  link.set_response_timeout(test_response_timeout_s);
  const mb::LinkResult next = exchange(link, 200, state);
  EXPECT_TRUE(next.ok()) << mb::describe(next);
  EXPECT_EQ(link.counters().bad_frames.load(), 0u);
  // The reply is this transaction's: the amplifier now holds the new command.
  EXPECT_EQ(amplifier_.state().torque_counts, 200);
  EXPECT_EQ(amplifier_.state().steps, 2u);
}

// The reply a transaction gets is its own, even when the previous request's
// reply comes late, after the next request has left. Here the amplifier
// answers request A 150 ms late, after A timed out (20 ms) and B was sent:
// A's reply arrives first. The read block covers the torque register, so
// each reply shows which command it answers (fc 23 writes, then reads).
// TCP pairs by transaction id: B gets B's reply and A's is dropped as late.
// RTU frames carry no id: B may take A's reply, but the flush before every
// request keeps it to that one (before, every reply was read one
// transaction late from then on, silently: an extra period of delay).
TEST_P(LinkTest, AReplyLaterThanTheNextRequestIsNotTakenForTheNextReplies) {
  mb::ModbusLink link(settings(0.02));
  link.open();
  ASSERT_TRUE(link.write_register(12, 0x0001).ok());
  std::array<std::uint16_t, 12> state{};  // position ... fault, 6-9, torque at 10, watchdog at 11
  auto exchange_echo = [&](std::int16_t torque) {
    const std::array<std::uint16_t, 2> command{static_cast<std::uint16_t>(torque), 50};
    return link.write_and_read(10, command, 0, state);
  };
  server_->inject(mb::sim::Injection::late, 1, 0, 150);
  EXPECT_EQ(exchange_echo(100).outcome, LinkOutcome::timeout);
  link.set_response_timeout(2.0);
  const mb::LinkResult b = exchange_echo(200);
  ASSERT_TRUE(b.ok()) << mb::describe(b);
  if (!rtu()) {
    EXPECT_EQ(static_cast<std::int16_t>(state[10]), 200) << "B took A's reply";
    EXPECT_EQ(link.counters().late_replies.load(), 1u);
  } else {
    // B took A's reply: B's own is on its way; the next request must not take it.
    ASSERT_TRUE(late_reply_waiting(2)) << "B's reply never came";
  }
  for (std::int16_t torque = 300; torque < 310; ++torque) {
    const mb::LinkResult r = exchange_echo(torque);
    ASSERT_TRUE(r.ok()) << mb::describe(r);
    EXPECT_EQ(static_cast<std::int16_t>(state[10]), torque) << "a reply read one transaction late";
  }
  EXPECT_EQ(link.counters().bad_frames.load(), 0u);
  EXPECT_EQ(amplifier_.state().steps, 12u);  // every request was applied once
}

// Over TCP the link frames the stream itself: a reply split across
// segments, behind a late reply to an earlier request, is this request's;
// a stream that is not Modbus is a malformed reply, and the link starts
// afresh after it.
TEST(ModbusLinkTcp, RepliesArePairedByTransactionIdAcrossSegments) {
  const int listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), len), 0);
  ASSERT_EQ(listen(listener, 1), 0);
  ASSERT_EQ(getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  mb::LinkSettings s;
  s.transport = mb::Transport::tcp;
  s.port = ntohs(addr.sin_port);
  s.slave_id = 0x11;
  s.response_timeout_s = 5.0;  // only the peer below decides
  mb::ModbusLink link(s);
  link.open();
  const int peer = accept(listener, nullptr, nullptr);
  ASSERT_GE(peer, 0);
  std::array<std::uint16_t, 1> out{};
  auto answer = [&](auto reply) {
    mb::LinkResult result;
    std::thread t([&] { result = link.read_registers(mb::ReadTable::holding, 0x0008, out); });
    const Bytes request = read_bytes(peer, 12);
    EXPECT_EQ(request.size(), 12u);
    reply(static_cast<std::uint16_t>((request[0] << 8) | request[1]));
    t.join();
    return result;
  };
  const Bytes value = pdu([](auto o) {
    const std::array<std::uint16_t, 1> v{0x000A};
    return mb::build_read_registers_response(o, 0x03, v);
  });
  mb::LinkResult r = answer([&](std::uint16_t id) {
    Bytes bytes = tcp(static_cast<std::uint16_t>(id - 1), 0x11, value);  // late
    const Bytes mine = tcp(id, 0x11, value);
    bytes.insert(bytes.end(), mine.begin(), mine.begin() + 5);
    ASSERT_EQ(::write(peer, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_EQ(::write(peer, mine.data() + 5, mine.size() - 5), static_cast<ssize_t>(mine.size() - 5));
  });
  EXPECT_TRUE(r.ok()) << mb::describe(r);
  EXPECT_EQ(out[0], 0x000A);
  EXPECT_EQ(link.counters().late_replies.load(), 1u);
  r = answer([&](std::uint16_t id) {
    Bytes bytes = tcp(id, 0x11, value);
    bytes[3] = 0x01;  // protocol id 1: not Modbus
    ASSERT_EQ(::write(peer, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  });
  EXPECT_EQ(r.outcome, LinkOutcome::bad_frame);
  EXPECT_EQ(mb::describe(r),
            "malformed reply in reply to function 0x03 (MBAP protocol id 0x0001, not 0 (Modbus))");
  r = answer([&](std::uint16_t id) {
    const Bytes bytes = tcp(id, 0x11, value);
    ASSERT_EQ(::write(peer, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  });
  EXPECT_TRUE(r.ok()) << mb::describe(r);
  EXPECT_EQ(link.counters().requests.load(), 3u);
  EXPECT_EQ(link.counters().responses.load(), 3u);
  link.close();
  close(peer);
  close(listener);
}

}  // namespace link_test
