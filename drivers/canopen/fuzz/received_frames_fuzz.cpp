// libFuzzer target: every CAN frame a drive (or anything else on the bus)
// could send, through the decoders the driver uses on the RT path
// (CyclicExchange::on_frame, the SDO client's response decoder, EMCY,
// heartbeat). The input is a sequence of 13-byte records: can_id (4 bytes,
// little-endian, SocketCAN flag bits included), length code, 8 data bytes;
// every third record ends a period with a command taken from the record.
// Must hold: nothing crashes or reads out of bounds; a period sends at most
// its 4 frames, each with a length code of at most 8; a reading is finite;
// an expedited SDO upload indicates at most 4 bytes; an EMCY decodes back
// to the same frame (CiA 301 7.2.7.3.1: always 8 bytes); and nothing
// malformed passes quietly (issue 17): an EMCY of the drive of other than 8
// bytes, a heartbeat of other than 1 byte or with no NMT state, a boot-up
// after the setup, and a length code over 8 (which the socket refuses as no
// can_frame: fed as on_malformed_message, as the session does) each leave the
// exchange faulted.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/emcy.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/sdo.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"

namespace {

namespace canopen = hapticd::drivers::canopen;
namespace co = hapticd::drivers::canopen::cia301;

constexpr std::uint8_t node = 5;
constexpr std::size_t record_bytes = 13;

void require(bool holds) {
  if (!holds) __builtin_trap();
}

canopen::CyclicSettings settings() {
  canopen::CyclicSettings s;
  s.node = node;
  s.mapping = canopen::standard_mapping(node, true);
  s.scaling.si_per_count = 1e-4;
  s.scaling.si_per_velocity_unit = 1e-3;
  s.scaling.force_per_permille = 1e-3;
  s.tpdo_timeout_periods = 3;
  s.heartbeat_every_periods = 2;
  s.drive_heartbeat_timeout_periods = 4;
  s.reset_timeout_periods = 8;
  return s;
}

co::Frame frame_of(const std::uint8_t* record) {
  co::Frame f;
  std::uint32_t id = 0;
  std::memcpy(&id, record, sizeof id);
  f.id = id;
  f.len = record[4];  // deliberately unchecked: a driver must not trust it
  std::memcpy(f.data.data(), record + 5, f.data.size());
  return f;
}

void check_codecs(const co::Frame& f) {
  if (const auto sdo = co::decode_sdo_response(f, node);
      sdo && sdo->kind == co::SdoResponse::Kind::upload_expedited)
    require(sdo->size <= 4);
  if (const auto emcy = co::decode_emergency(f, node)) {
    const co::Frame back = co::encode_emergency(node, *emcy);
    require(back.id == f.id && back.len == 8 && back.data == f.data);
  }
  (void)co::decode_heartbeat(f);
  (void)co::decode_nmt(f);
}

/// Must the exchange have latched a fault on this frame of the drive's?
bool must_fault(const co::Frame& f) {
  if (!co::is_standard_data_frame(f)) return false;
  if (f.id == co::emcy_id(node)) return f.len != 8;
  if (f.id != co::heartbeat_id(node)) return false;
  const auto hb = co::decode_heartbeat(f);
  return !hb || hb->state == co::NmtState::boot_up;
}

/// One received message the way the session's read() takes it.
void receive(canopen::CyclicExchange& exchange, const co::Frame& f) {
  if (f.len > 8) {  // the socket's verdict: a can_frame with len over 8 is no frame
    canopen::MalformedMessage m;
    m.bytes = 16;
    m.can_id = f.id;
    m.can_len = f.len;
    exchange.on_malformed_message(m);
    require(exchange.faulted());
    return;
  }
  (void)exchange.on_frame(f);
  if (must_fault(f)) require(exchange.faulted());
}

void end_period(canopen::CyclicExchange& exchange, const std::uint8_t* record) {
  const canopen::CycleReading reading = exchange.begin_period();
  require(std::isfinite(reading.position) && std::isfinite(reading.velocity));
  std::int8_t command = 0;
  std::memcpy(&command, record + 12, 1);
  std::array<co::Frame, 4> out{};
  const std::size_t sent = exchange.end_period(command / 100.0, out);
  require(sent <= out.size());
  for (std::size_t i = 0; i < sent; ++i) require(out[i].len <= 8);
  if (record[0] & 0x40U) exchange.set_enabled((record[0] & 0x80U) != 0);
  if (exchange.faulted() && (record[1] & 0x01U)) exchange.request_fault_reset();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  canopen::CyclicExchange exchange(settings());
  for (std::size_t i = 0; i + record_bytes <= size; i += record_bytes) {
    const co::Frame f = frame_of(data + i);
    check_codecs(f);
    receive(exchange, f);
    if ((i / record_bytes) % 3 == 2) end_period(exchange, data + i);
  }
  return 0;
}
