// The transport on the frame seam: AF_UNIX SOCK_SEQPACKET carrying the
// 16-byte struct can_frame in host byte order, the user-space filters that
// make it deliver what AF_CAN would, and never blocking. The same round trip
// runs on vcan0 where the kernel has AF_CAN, and says why it is skipped
// otherwise.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/can_error.hpp"
#include "drivers/canopen/can_socket.hpp"

namespace can_socket_test {

namespace canopen = hapticd::drivers::canopen;
using canopen::CanSocket;
using canopen::IoStatus;
using hapticd::drivers::canopen::cia301::Frame;

namespace {

Frame make(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (const std::uint8_t b : bytes) f.data[i++] = b;
  return f;
}

std::string scratch_path(const char* name) {
  return (std::filesystem::temp_directory_path() /
          (std::string("hapticd-canopen-") + name + "-" + std::to_string(::getpid())))
      .string();
}

}  // namespace

TEST(CanopenCanSocket, PairCarriesFramesUnchanged) {
  auto [a, b] = CanSocket::pair();
  const Frame sent = make(0x605, {0x2B, 0x71, 0x60, 0x00, 0x9C, 0xFF, 0x00, 0x00});
  ASSERT_EQ(a.send(sent), IoStatus::ok);
  Frame got;
  ASSERT_EQ(b.receive(got), IoStatus::ok);
  EXPECT_EQ(got, sent);
  EXPECT_EQ(b.receive(got), IoStatus::would_block);  // nothing more, and no wait
}

TEST(CanopenCanSocket, OnTheWireItIsStructCanFrameInHostOrder) {
  auto [a, b] = CanSocket::pair();
  ASSERT_EQ(a.send(make(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF})), IoStatus::ok);
  // Room for more than a can_frame, so a longer message would show as one.
  unsigned char bytes[sizeof(can_frame) + 8] = {};
  ASSERT_EQ(::recv(b.fd(), bytes, sizeof bytes, 0),
            static_cast<ssize_t>(sizeof(can_frame)));  // one message, 16 bytes
  can_frame raw{};
  std::memcpy(&raw, bytes, sizeof raw);
  EXPECT_EQ(raw.can_id, 0x185U);
  EXPECT_EQ(raw.len, 6);
  const std::uint8_t data[] = {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(std::memcmp(raw.data, data, sizeof data), 0);

  // And a struct can_frame written by hand is read back as that frame.
  can_frame hand{};
  hand.can_id = 0x77F;
  hand.len = 1;
  hand.data[0] = 0x05;
  ASSERT_EQ(::send(b.fd(), &hand, sizeof hand, 0), static_cast<ssize_t>(sizeof hand));
  Frame got;
  ASSERT_EQ(a.receive(got), IoStatus::ok);
  EXPECT_EQ(got, make(0x77F, {0x05}));
}

TEST(CanopenCanSocket, AFullTransmitQueueDropsInsteadOfBlocking) {
  auto [a, b] = CanSocket::pair();
  const Frame f = make(0x080, {});
  int sent = 0;
  IoStatus status = IoStatus::ok;
  for (; sent < 100000 && status == IoStatus::ok; ++sent) status = a.send(f);
  EXPECT_EQ(status, IoStatus::would_block);  // the peer never reads: the queue fills, send returns
  EXPECT_TRUE(a.last_errno() == EAGAIN || a.last_errno() == ENOBUFS) << a.last_errno();
  EXPECT_GT(sent, 1);
}

TEST(CanopenCanSocket, ClosedPeerIsReported) {
  auto [a, b] = CanSocket::pair();
  b.close();
  Frame got;
  EXPECT_EQ(a.receive(got), IoStatus::closed);
  EXPECT_EQ(a.send(make(0x080, {})), IoStatus::closed);
}

// Issue 17: a peer on the seam writes what it likes. Only a message of
// exactly sizeof(struct can_frame) with len 0..8 is a frame; anything else is
// reported as what it is, never cut to 16 bytes.
TEST(CanopenCanSocket, AMessageOfAnotherSizeIsMalformedNotCutToAFrame) {
  auto [driver, peer] = CanSocket::pair();
  can_frame tpdo{};
  tpdo.can_id = 0x185;
  tpdo.len = 6;
  tpdo.data[0] = 0x37;
  unsigned char oversize[72] = {};
  std::memcpy(oversize, &tpdo, sizeof tpdo);  // its first 16 bytes are a TPDO
  ASSERT_EQ(::send(peer.fd(), oversize, sizeof oversize, 0), 72);
  ASSERT_EQ(::send(peer.fd(), oversize, 5, 0), 5);
  unsigned char huge[300] = {};
  ASSERT_EQ(::send(peer.fd(), huge, sizeof huge, 0), 300);
  ASSERT_EQ(::send(peer.fd(), &tpdo, sizeof tpdo, 0), 16);
  Frame got;
  ASSERT_EQ(driver.receive(got), IoStatus::malformed);
  EXPECT_EQ(driver.last_malformed().bytes, 72U);
  EXPECT_EQ(canopen::describe(driver.last_malformed()),
            "a 72-byte message on the CAN socket: not a can_frame (16 bytes)");
  ASSERT_EQ(driver.receive(got), IoStatus::malformed);
  EXPECT_EQ(canopen::describe(driver.last_malformed()),
            "a 5-byte message on the CAN socket: not a can_frame (16 bytes)");
  ASSERT_EQ(driver.receive(got), IoStatus::malformed);  // MSG_TRUNC tells the real length
  EXPECT_EQ(canopen::describe(driver.last_malformed()),
            "a 300-byte message on the CAN socket: not a can_frame (16 bytes)");
  ASSERT_EQ(driver.receive(got), IoStatus::ok);  // each message consumed whole: the next frame is intact
  EXPECT_EQ(got, make(0x185, {0x37, 0, 0, 0, 0, 0}));
  EXPECT_EQ(driver.receive(got), IoStatus::would_block);
}

TEST(CanopenCanSocket, AnEmptyMessageIsMalformedWhileThePeerLivesAndTheEndOnceItHungUp) {
  auto [driver, peer] = CanSocket::pair();
  ASSERT_EQ(::send(peer.fd(), "", 0, 0), 0);
  Frame got;
  ASSERT_EQ(driver.receive(got), IoStatus::malformed);
  EXPECT_EQ(canopen::describe(driver.last_malformed()),
            "a 0-byte message on the CAN socket: not a can_frame (16 bytes)");
  EXPECT_EQ(driver.receive(got), IoStatus::would_block);
  peer.close();
  EXPECT_EQ(driver.receive(got), IoStatus::closed);
}

TEST(CanopenCanSocket, ACanFrameClaimingMoreThan8DataBytesIsMalformed) {
  auto [driver, peer] = CanSocket::pair();
  can_frame cf{};
  cf.can_id = 0x085;
  cf.len = 15;
  ASSERT_EQ(::send(peer.fd(), &cf, sizeof cf, 0), 16);
  Frame got;
  ASSERT_EQ(driver.receive(got), IoStatus::malformed);
  EXPECT_EQ(driver.last_malformed().can_len, 15);
  EXPECT_EQ(canopen::describe(driver.last_malformed()),
            "a can_frame with len 15 (id 0x085) on the CAN socket: a classic frame carries 0..8 data bytes");
}

TEST(CanopenCanSocket, UnixInterfaceFiltersLikeCanRaw) {
  const std::string path = scratch_path("filters");
  auto listener = canopen::CanListener::listen(path);
  const canopen::CanFilter filters[] = {canopen::exact_standard_filter(0x185),
                                        canopen::exact_standard_filter(0x585)};
  CanSocket driver = CanSocket::open("unix:" + path, filters, CAN_ERR_BUSOFF);
  CanSocket bus = listener.accept(std::chrono::seconds(5));
  ASSERT_TRUE(bus.is_open());

  Frame rtr = make(0x185, {});
  rtr.id |= CAN_RTR_FLAG;
  Frame extended = make(0x185, {1});
  extended.id |= CAN_EFF_FLAG;
  Frame bus_error = make(CAN_ERR_FLAG | CAN_ERR_BUSERROR, {0, 0, 0, 0, 0, 0, 0, 0});
  Frame bus_off = make(CAN_ERR_FLAG | CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0});
  for (const Frame& f :
       {make(0x186, {1}), rtr, extended, make(0x185, {2}), bus_error, make(0x585, {3}), bus_off})
    ASSERT_EQ(bus.send(f), IoStatus::ok);
  ASSERT_TRUE(driver.wait_readable(std::chrono::seconds(5)));
  Frame got;
  ASSERT_EQ(driver.receive(got), IoStatus::ok);
  EXPECT_EQ(got, make(0x185, {2}));
  ASSERT_EQ(driver.receive(got), IoStatus::ok);
  EXPECT_EQ(got, make(0x585, {3}));
  ASSERT_EQ(driver.receive(got), IoStatus::ok);
  EXPECT_EQ(got.id, CAN_ERR_FLAG | CAN_ERR_BUSOFF);
  EXPECT_EQ(driver.receive(got), IoStatus::would_block);
  listener.close();
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(CanopenCanSocket, OpenErrorsAreOneLineWithWhatToDo) {
  try {
    CanSocket::open("unix:/nonexistent/hapticd-bus", {}, 0);
    FAIL() << "connected to nothing";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cannot connect to the simulated bus at /nonexistent/hapticd-bus"), std::string::npos)
        << what;
    EXPECT_NE(what.find("hapticd-devsim canopen"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
  try {
    CanSocket::open("nocan9", {}, 0);
    FAIL() << "opened a CAN interface that does not exist";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("CAN interface 'nocan9'"), std::string::npos) << what;
    // Either this kernel lacks AF_CAN, or it has it and the interface is missing: both say so.
    EXPECT_TRUE(what.find("no AF_CAN") != std::string::npos ||
                what.find("no such network interface") != std::string::npos)
        << what;
  }
}

TEST(CanopenCanSocket, ListenerNeverReplacesAFileThatIsNotASocket) {
  const std::string path = scratch_path("regular-file");
  { std::ofstream(path) << "keep me"; }
  EXPECT_THROW(canopen::CanListener::listen(path), std::runtime_error);
  EXPECT_TRUE(std::filesystem::is_regular_file(path));
  std::filesystem::remove(path);
}

TEST(CanopenCanSocket, ErrorFramesDecoded) {
  const auto off = canopen::decode_error_frame(make(CAN_ERR_FLAG | CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(off.severity, canopen::BusErrorSeverity::fault);
  EXPECT_EQ(canopen::describe(off), "CAN bus-off");
  const auto passive = canopen::decode_error_frame(
      make(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(passive.severity, canopen::BusErrorSeverity::fault);
  EXPECT_EQ(canopen::describe(passive), "CAN controller problem: TX error passive");
  const auto warning = canopen::decode_error_frame(
      make(CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_WARNING, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(warning.severity, canopen::BusErrorSeverity::notice);
  const auto restarted =
      canopen::decode_error_frame(make(CAN_ERR_FLAG | CAN_ERR_RESTARTED, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(restarted.severity, canopen::BusErrorSeverity::notice);
  EXPECT_EQ(canopen::decode_error_frame(make(0x085, {0})).severity, canopen::BusErrorSeverity::none);
  EXPECT_EQ(canopen::subscribed_error_classes(),
            CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_ACK | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED);
  EXPECT_EQ(canopen::subscribed_error_classes() & (CAN_ERR_BUSERROR | CAN_ERR_LOSTARB),
            0U);  // these can flood
}

// The same round trip on a real kernel CAN interface, where there is one.
TEST(CanopenCanSocket, VcanRoundTrip) {
  const int probe = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (probe < 0)
    GTEST_SKIP() << "this kernel has no AF_CAN (socket(PF_CAN) failed: " << std::strerror(errno) << ")";
  ::close(probe);
  if (if_nametoindex("vcan0") == 0)
    GTEST_SKIP() << "no vcan0 (ip link add dev vcan0 type vcan; ip link set vcan0 up)";
  const canopen::CanFilter filters[] = {canopen::exact_standard_filter(0x185)};
  CanSocket driver = CanSocket::open("vcan0", filters, canopen::subscribed_error_classes());
  CanSocket peer = CanSocket::open("vcan0", {}, 0);
  ASSERT_EQ(peer.send(make(0x186, {1})), IoStatus::ok);
  ASSERT_EQ(peer.send(make(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF})), IoStatus::ok);
  ASSERT_TRUE(driver.wait_readable(std::chrono::seconds(2)));
  Frame got;
  ASSERT_EQ(driver.receive(got), IoStatus::ok);
  EXPECT_EQ(got, make(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF}));
}

}  // namespace can_socket_test
