#include "drivers/canopen/exchange_status.hpp"

#include "drivers/canopen/402/state_machine.hpp"

namespace hapticd::drivers::canopen {

using rt::seq_load;
using rt::seq_store;

/// One atomic per figure: the seqlock's data (rt/seqlock.hpp).
struct PublishedCells {
  // The fault record.
  std::atomic<std::uint8_t> fault_kind{0};
  std::atomic<std::uint16_t> emcy_code{0};
  std::atomic<std::uint8_t> emcy_register{0};
  std::atomic<std::uint64_t> emcy_manufacturer{0};
  std::atomic<std::uint16_t> fault_statusword{0};
  std::atomic<std::uint32_t> fault_periods{0};
  std::atomic<std::uint8_t> fault_nmt{0};
  std::atomic<std::uint32_t> bus_classes{0};
  std::atomic<std::uint8_t> bus_controller{0};
  std::atomic<std::uint8_t> bus_severity{0};
  std::atomic<int> link_errno{0};
  std::atomic<bool> link_closed{false};
  std::atomic<std::uint8_t> malformed{0};
  std::atomic<std::uint32_t> frame_id{0};
  std::atomic<std::uint8_t> frame_len{0};
  std::atomic<std::uint64_t> frame_data{0};
  std::atomic<std::uint32_t> message_bytes{0};
  std::atomic<bool> message_truncated{false};
  std::atomic<std::uint32_t> message_can_id{0};
  std::atomic<std::uint8_t> message_can_len{0};
  std::atomic<std::uint32_t> rated_before{0}, rated_after{0};
  // The drive and what went out.
  std::atomic<bool> resetting{false};
  std::atomic<bool> operational{false};
  std::atomic<std::uint16_t> statusword{0};
  std::atomic<std::uint16_t> controlword{0};
  std::atomic<std::int16_t> torque{0};
  // The counters.
  std::atomic<std::uint64_t> periods{0}, tpdos{0}, late_tpdos{0}, short_tpdos{0}, emcys{0}, error_frames{0},
      drive_heartbeats{0}, tx_dropped{0}, malformed_frames{0}, malformed_messages{0};
};

namespace {

template <std::size_t N>
std::uint64_t pack_bytes(const std::array<std::uint8_t, N>& bytes) noexcept {
  static_assert(N <= 8);
  std::uint64_t word = 0;
  for (std::size_t i = 0; i < N; ++i) word |= static_cast<std::uint64_t>(bytes[i]) << (8 * i);
  return word;
}

template <std::size_t N>
void unpack_bytes(std::uint64_t word, std::array<std::uint8_t, N>& bytes) noexcept {
  for (std::size_t i = 0; i < N; ++i) bytes[i] = static_cast<std::uint8_t>(word >> (8 * i));
}

void store_fault(PublishedCells& s, const FaultRecord& f) noexcept {
  seq_store(s.fault_kind, static_cast<std::uint8_t>(f.kind));
  seq_store(s.emcy_code, f.emcy.error_code);
  seq_store(s.emcy_register, f.emcy.error_register);
  seq_store(s.emcy_manufacturer, pack_bytes(f.emcy.manufacturer));
  seq_store(s.fault_statusword, f.statusword);
  seq_store(s.fault_periods, f.periods);
  seq_store(s.fault_nmt, static_cast<std::uint8_t>(f.nmt));
  seq_store(s.bus_classes, f.bus.classes);
  seq_store(s.bus_controller, f.bus.controller);
  seq_store(s.bus_severity, static_cast<std::uint8_t>(f.bus.severity));
  seq_store(s.link_errno, f.link_errno);
  seq_store(s.link_closed, f.link_closed);
  seq_store(s.malformed, static_cast<std::uint8_t>(f.malformed));
  seq_store(s.frame_id, f.frame.id);
  seq_store(s.frame_len, f.frame.len);
  seq_store(s.frame_data, pack_bytes(f.frame.data));
  seq_store(s.message_bytes, f.message.bytes);
  seq_store(s.message_truncated, f.message.truncated);
  seq_store(s.message_can_id, f.message.can_id);
  seq_store(s.message_can_len, f.message.can_len);
  seq_store(s.rated_before, f.rated_before);
  seq_store(s.rated_after, f.rated_after);
}

FaultRecord load_fault(const PublishedCells& s) noexcept {
  FaultRecord f;
  f.kind = static_cast<FaultKind>(seq_load(s.fault_kind));
  f.emcy.error_code = seq_load(s.emcy_code);
  f.emcy.error_register = seq_load(s.emcy_register);
  unpack_bytes(seq_load(s.emcy_manufacturer), f.emcy.manufacturer);
  f.statusword = seq_load(s.fault_statusword);
  f.periods = seq_load(s.fault_periods);
  f.nmt = static_cast<cia301::NmtState>(seq_load(s.fault_nmt));
  f.bus.classes = seq_load(s.bus_classes);
  f.bus.controller = seq_load(s.bus_controller);
  f.bus.severity = static_cast<BusErrorSeverity>(seq_load(s.bus_severity));
  f.link_errno = seq_load(s.link_errno);
  f.link_closed = seq_load(s.link_closed);
  f.malformed = static_cast<MalformedFrame>(seq_load(s.malformed));
  f.frame.id = seq_load(s.frame_id);
  f.frame.len = seq_load(s.frame_len);
  unpack_bytes(seq_load(s.frame_data), f.frame.data);
  f.message.bytes = seq_load(s.message_bytes);
  f.message.truncated = seq_load(s.message_truncated);
  f.message.can_id = seq_load(s.message_can_id);
  f.message.can_len = seq_load(s.message_can_len);
  f.rated_before = seq_load(s.rated_before);
  f.rated_after = seq_load(s.rated_after);
  return f;
}

void store_counters(PublishedCells& s, const CyclicCounters& c) noexcept {
  seq_store(s.periods, c.periods);
  seq_store(s.tpdos, c.tpdos);
  seq_store(s.late_tpdos, c.late_tpdos);
  seq_store(s.short_tpdos, c.short_tpdos);
  seq_store(s.emcys, c.emcys);
  seq_store(s.error_frames, c.error_frames);
  seq_store(s.drive_heartbeats, c.drive_heartbeats);
  seq_store(s.tx_dropped, c.tx_dropped);
  seq_store(s.malformed_frames, c.malformed_frames);
  seq_store(s.malformed_messages, c.malformed_messages);
}

CyclicCounters load_counters(const PublishedCells& s) noexcept {
  CyclicCounters c;
  c.periods = seq_load(s.periods);
  c.tpdos = seq_load(s.tpdos);
  c.late_tpdos = seq_load(s.late_tpdos);
  c.short_tpdos = seq_load(s.short_tpdos);
  c.emcys = seq_load(s.emcys);
  c.error_frames = seq_load(s.error_frames);
  c.drive_heartbeats = seq_load(s.drive_heartbeats);
  c.tx_dropped = seq_load(s.tx_dropped);
  c.malformed_frames = seq_load(s.malformed_frames);
  c.malformed_messages = seq_load(s.malformed_messages);
  return c;
}

}  // namespace

PublishedExchange::PublishedExchange() : cells_(std::make_unique<PublishedCells>()) {}

PublishedExchange::~PublishedExchange() = default;

void PublishedExchange::publish(const CyclicExchange& x) noexcept {
  PublishedCells& s = *cells_;
  version_.write_begin();
  store_fault(s, x.fault());
  seq_store(s.resetting, x.resetting());
  seq_store(s.operational, x.operational());
  seq_store(s.statusword, x.statusword());
  seq_store(s.controlword, x.last_controlword());
  seq_store(s.torque, x.last_torque_permille());
  store_counters(s, x.counters());
  version_.write_end();
  publications_.fetch_add(1, std::memory_order_release);
}

ExchangeStatus PublishedExchange::load(const CyclicSettings& settings) const {
  ExchangeStatus st;
  FaultRecord f;
  const PublishedCells& s = *cells_;
  version_.read([&] {
    f = load_fault(s);
    st.resetting = seq_load(s.resetting);
    st.operational = seq_load(s.operational);
    st.statusword = seq_load(s.statusword);
    st.controlword = seq_load(s.controlword);
    st.torque_permille = seq_load(s.torque);
    st.counters = load_counters(s);
  });
  st.fault_kind = f.kind;
  st.faulted = f.kind != FaultKind::none;
  st.fault_reason = describe(f, settings);
  const auto state = cia402::decode_statusword(st.statusword);
  st.drive_state = state ? std::string(cia402::to_string(*state)) : "unknown";
  return st;
}

}  // namespace hapticd::drivers::canopen
