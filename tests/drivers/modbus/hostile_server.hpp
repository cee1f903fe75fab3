#pragma once
// A hostile Modbus TCP server on 127.0.0.1 for the driver's tests. It serves
// the default register map well enough for configure and enable (writes land
// in 64 holding registers; the status register 4 shows bit 0 = the power
// stage while the control word 12 has bit 0), and misbehaves on command:
// another unit id in its replies, a wrong MBAP length, or silence. Its frames
// are built byte by byte here from the published layouts -- Modbus Messaging
// on TCP/IP Implementation Guide V1.0b 3.1.3 (MBAP: transaction id, protocol
// id 0, length = unit id + PDU, unit id) and Modbus Application Protocol
// V1.1b3 6.3, 6.5, 6.6, 6.12, 6.17 (the PDUs) -- not with the driver's
// codec, so a mistake there cannot hide on both sides.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <thread>
#include <vector>

namespace hapticd::drivers::modbus::testing {

class HostileServer {
 public:
  using Bytes = std::vector<std::uint8_t>;

  HostileServer() {
    listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (listener_ < 0 || ::bind(listener_, reinterpret_cast<sockaddr*>(&addr), len) != 0 ||
        ::listen(listener_, 4) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
      throw std::runtime_error("hostile server: cannot listen on 127.0.0.1");
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { run(); });
  }
  ~HostileServer() {
    stop_ = true;
    thread_.join();
    ::close(listener_);
  }
  HostileServer(const HostileServer&) = delete;
  HostileServer& operator=(const HostileServer&) = delete;

  int port() const { return port_; }

  // ---- what it does wrong (any thread) ----
  std::atomic<int> reply_unit{-1};         ///< -1: the request's unit id, as a server must
  std::atomic<int> length_error{0};        ///< added to the MBAP length field of each reply
  std::atomic<bool> silent{false};         ///< reads every request, answers none
  std::atomic<std::uint64_t> requests{0};  ///< request ADUs received

 private:
  static std::uint16_t be16(const Bytes& b, std::size_t at) {
    return static_cast<std::uint16_t>((b[at] << 8) | b[at + 1]);
  }
  static void put16(Bytes& b, std::uint16_t v) {
    b.push_back(static_cast<std::uint8_t>(v >> 8));
    b.push_back(static_cast<std::uint8_t>(v & 0xFF));
  }

  void run() {
    while (!stop_) {
      pollfd p{listener_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const int client = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (client < 0) continue;
      serve(client);
      ::close(client);
    }
  }

  void serve(int client) {
    Bytes stream;
    while (!stop_) {
      pollfd p{client, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      std::array<std::uint8_t, 512> chunk{};
      const ssize_t got = ::read(client, chunk.data(), chunk.size());
      if (got <= 0) return;  // the client closed: wait for the next one
      stream.insert(stream.end(), chunk.begin(), chunk.begin() + got);
      // MBAP: 7 bytes, the length (bytes 4-5) counting the unit id and the PDU.
      while (stream.size() >= 7 && stream.size() >= 6u + be16(stream, 4)) {
        const std::size_t size = 6u + be16(stream, 4);
        const Bytes adu(stream.begin(), stream.begin() + static_cast<std::ptrdiff_t>(size));
        stream.erase(stream.begin(), stream.begin() + static_cast<std::ptrdiff_t>(size));
        requests.fetch_add(1);
        if (silent) continue;
        const Bytes reply = answer(adu);
        if (::send(client, reply.data(), reply.size(), MSG_NOSIGNAL) < 0) return;
      }
    }
  }

  Bytes answer(const Bytes& adu) {
    const Bytes pdu(adu.begin() + 7, adu.end());
    Bytes out;
    try {
      out = respond(pdu);
    } catch (const std::out_of_range&) {
      out = Bytes{static_cast<std::uint8_t>(pdu.at(0) | 0x80), 0x02};  // 7: illegal data address
    }
    Bytes frame;
    put16(frame, be16(adu, 0));  // transaction id, copied
    put16(frame, 0);             // protocol id: Modbus
    put16(frame, static_cast<std::uint16_t>(out.size() + 1 + length_error));
    frame.push_back(reply_unit < 0 ? adu[6] : static_cast<std::uint8_t>(reply_unit));
    frame.insert(frame.end(), out.begin(), out.end());
    return frame;
  }

  Bytes read_block(std::uint8_t function, std::uint16_t address, std::uint16_t count) {
    registers_[4] =
        (registers_[12] & 1u) != 0 ? 1 : 0;  // status bit 0: the power stage follows the enable bit
    Bytes out{function, static_cast<std::uint8_t>(2 * count)};
    for (std::uint16_t i = 0; i < count; ++i) put16(out, registers_.at(address + i));
    return out;
  }

  Bytes respond(const Bytes& pdu) {
    const std::uint8_t function = pdu.at(0);
    switch (function) {
      case 0x03:  // 6.3: address, count -> byte count, registers
      case 0x04:
        return read_block(function, be16(pdu, 1), be16(pdu, 3));
      case 0x05:  // 6.5, 6.6: the reply echoes the request
        return pdu;
      case 0x06:
        registers_.at(be16(pdu, 1)) = be16(pdu, 3);
        return pdu;
      case 0x10: {  // 6.12: address, count, byte count, values -> address, count
        const std::uint16_t address = be16(pdu, 1), count = be16(pdu, 3);
        for (std::uint16_t i = 0; i < count; ++i) registers_.at(address + i) = be16(pdu, 6 + 2 * i);
        return Bytes(pdu.begin(), pdu.begin() + 5);
      }
      case 0x17: {  // 6.17: read address, read count, write address, write count, bytes, values
        const std::uint16_t write_address = be16(pdu, 5), write_count = be16(pdu, 7);
        for (std::uint16_t i = 0; i < write_count; ++i)
          registers_.at(write_address + i) = be16(pdu, 10 + 2 * i);
        return read_block(0x17, be16(pdu, 1), be16(pdu, 3));
      }
      default:
        return Bytes{static_cast<std::uint8_t>(function | 0x80), 0x01};  // 7: illegal function
    }
  }

  int listener_ = -1;
  int port_ = 0;
  std::array<std::uint16_t, 64> registers_{};  ///< server thread only
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace hapticd::drivers::modbus::testing
