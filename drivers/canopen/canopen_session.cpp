#include "drivers/canopen/canopen_session.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <thread>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/402/objects.hpp"
#include "drivers/canopen/commissioning.hpp"

namespace hapticd::drivers::canopen {

using cia301::Frame;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::size_t sdo_ring_capacity = 64;
constexpr std::size_t unit_ring_capacity = 8;
constexpr double enable_timeout_s = 1.0;
constexpr double reset_timeout_s = 1.0;
constexpr int prime_attempts = 3;
constexpr double clear_loop_wait_s = 0.1;

std::uint64_t periods_in(double seconds, double period_s) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(seconds / period_s - 1e-9)));
}

}  // namespace

// ---- links for the SDO client ------------------------------------------------

/// Before the loop runs: the SDO client owns the socket. Once configured, the
/// exchange's frames (TPDOs, EMCYs, heartbeats) go to the exchange, not lost
/// to the SDO client, and a message that is no frame faults it.
class CanopenSession::SocketLink final : public FrameLink {
 public:
  explicit SocketLink(CanSocket& socket, CyclicExchange* exchange = nullptr)
      : socket_(socket), exchange_(exchange) {}
  bool send(const Frame& frame) override {
    const IoStatus s = socket_.send(frame);
    if (s == IoStatus::closed) error_ = "the bus connection closed";
    return s == IoStatus::ok;
  }
  bool receive(Frame& frame, Clock::time_point deadline) override {
    for (;;) {
      const IoStatus s = socket_.receive(frame);
      if (s == IoStatus::ok) {
        if (exchange_ == nullptr || exchange_->on_frame(frame) == FrameUse::sdo_response) return true;
        continue;
      }
      if (s == IoStatus::malformed) {
        if (exchange_ != nullptr) exchange_->on_malformed_message(socket_.last_malformed());
        error_ = describe(socket_.last_malformed());
        return false;
      }
      if (s == IoStatus::closed) {
        error_ = "the bus connection closed";
        return false;
      }
      if (s == IoStatus::error) {
        error_ = "socket error " + std::to_string(socket_.last_errno());
        return false;
      }
      const auto now = Clock::now();
      if (now >= deadline) return false;
      socket_.wait_readable(std::chrono::duration_cast<std::chrono::microseconds>(deadline - now));
    }
  }
  std::string link_error() const override { return error_; }

 private:
  CanSocket& socket_;
  CyclicExchange* exchange_;
  std::string error_;
};

/// While the loop runs: requests go straight out (send(2) keeps message
/// boundaries across threads); answers come from the loop through the ring.
class CanopenSession::RingLink final : public FrameLink {
 public:
  RingLink(CanSocket& socket, rt::SpscRing<Frame>& ring) : socket_(socket), ring_(ring) {
    Frame stale;
    while (ring_.try_pop(stale)) {
    }
  }
  bool send(const Frame& frame) override { return socket_.send(frame) == IoStatus::ok; }
  bool receive(Frame& frame, Clock::time_point deadline) override {
    for (;;) {
      if (ring_.try_pop(frame)) return true;
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  }

 private:
  CanSocket& socket_;
  rt::SpscRing<Frame>& ring_;
};

// ---- status cells (written by the loop, read anywhere) -----------------------

struct CanopenSession::Cells {
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
  std::atomic<bool> resetting{false};
  std::atomic<bool> operational{false};
  std::atomic<std::uint16_t> statusword{0};
  std::atomic<std::uint16_t> controlword{0};
  std::atomic<std::int16_t> torque{0};
  std::atomic<std::uint64_t> periods{0}, tpdos{0}, late_tpdos{0}, short_tpdos{0}, emcys{0}, error_frames{0},
      drive_heartbeats{0}, tx_dropped{0}, malformed_frames{0}, malformed_messages{0}, faults{0};
};

CanopenSession::CanopenSession(CanopenConfig config)
    : config_(std::move(config)), cells_(std::make_unique<Cells>()) {
  validate(config_);
}

CanopenSession::~CanopenSession() { close(); }

void CanopenSession::publish() noexcept {
  const CyclicExchange& x = *exchange_;
  const FaultRecord& f = x.fault();
  const CyclicCounters& c = x.counters();
  Cells& s = *cells_;
  std::uint64_t manufacturer = 0;
  for (std::size_t i = 0; i < f.emcy.manufacturer.size(); ++i)
    manufacturer |= static_cast<std::uint64_t>(f.emcy.manufacturer[i]) << (8 * i);
  std::uint64_t frame_data = 0;
  for (std::size_t i = 0; i < f.frame.data.size(); ++i)
    frame_data |= static_cast<std::uint64_t>(f.frame.data[i]) << (8 * i);
  version_.write_begin();
  rt::seq_store(s.fault_kind, static_cast<std::uint8_t>(f.kind));
  rt::seq_store(s.emcy_code, f.emcy.error_code);
  rt::seq_store(s.emcy_register, f.emcy.error_register);
  rt::seq_store(s.emcy_manufacturer, manufacturer);
  rt::seq_store(s.fault_statusword, f.statusword);
  rt::seq_store(s.fault_periods, f.periods);
  rt::seq_store(s.fault_nmt, static_cast<std::uint8_t>(f.nmt));
  rt::seq_store(s.bus_classes, f.bus.classes);
  rt::seq_store(s.bus_controller, f.bus.controller);
  rt::seq_store(s.bus_severity, static_cast<std::uint8_t>(f.bus.severity));
  rt::seq_store(s.link_errno, f.link_errno);
  rt::seq_store(s.link_closed, f.link_closed);
  rt::seq_store(s.malformed, static_cast<std::uint8_t>(f.malformed));
  rt::seq_store(s.frame_id, f.frame.id);
  rt::seq_store(s.frame_len, f.frame.len);
  rt::seq_store(s.frame_data, frame_data);
  rt::seq_store(s.message_bytes, f.message.bytes);
  rt::seq_store(s.message_truncated, f.message.truncated);
  rt::seq_store(s.message_can_id, f.message.can_id);
  rt::seq_store(s.message_can_len, f.message.can_len);
  rt::seq_store(s.rated_before, f.rated_before);
  rt::seq_store(s.rated_after, f.rated_after);
  rt::seq_store(s.resetting, x.resetting());
  rt::seq_store(s.operational, x.operational());
  rt::seq_store(s.statusword, x.statusword());
  rt::seq_store(s.controlword, x.last_controlword());
  rt::seq_store(s.torque, x.last_torque_permille());
  rt::seq_store(s.periods, c.periods);
  rt::seq_store(s.tpdos, c.tpdos);
  rt::seq_store(s.late_tpdos, c.late_tpdos);
  rt::seq_store(s.short_tpdos, c.short_tpdos);
  rt::seq_store(s.emcys, c.emcys);
  rt::seq_store(s.error_frames, c.error_frames);
  rt::seq_store(s.drive_heartbeats, c.drive_heartbeats);
  rt::seq_store(s.tx_dropped, c.tx_dropped);
  rt::seq_store(s.malformed_frames, c.malformed_frames);
  rt::seq_store(s.malformed_messages, c.malformed_messages);
  rt::seq_store(s.faults, c.faults);
  version_.write_end();
  publications_.fetch_add(1, std::memory_order_release);
}

SessionStatus CanopenSession::status() const {
  SessionStatus st;
  st.configured = exchange_.has_value();
  st.enabled = enabled();
  if (!st.configured) return st;
  FaultRecord f;
  const Cells& s = *cells_;
  version_.read([&] {
    f.kind = static_cast<FaultKind>(rt::seq_load(s.fault_kind));
    f.emcy.error_code = rt::seq_load(s.emcy_code);
    f.emcy.error_register = rt::seq_load(s.emcy_register);
    const std::uint64_t m = rt::seq_load(s.emcy_manufacturer);
    for (std::size_t i = 0; i < f.emcy.manufacturer.size(); ++i)
      f.emcy.manufacturer[i] = static_cast<std::uint8_t>(m >> (8 * i));
    f.statusword = rt::seq_load(s.fault_statusword);
    f.periods = rt::seq_load(s.fault_periods);
    f.nmt = static_cast<cia301::NmtState>(rt::seq_load(s.fault_nmt));
    f.bus.classes = rt::seq_load(s.bus_classes);
    f.bus.controller = rt::seq_load(s.bus_controller);
    f.bus.severity = static_cast<BusErrorSeverity>(rt::seq_load(s.bus_severity));
    f.link_errno = rt::seq_load(s.link_errno);
    f.link_closed = rt::seq_load(s.link_closed);
    f.malformed = static_cast<MalformedFrame>(rt::seq_load(s.malformed));
    f.frame.id = rt::seq_load(s.frame_id);
    f.frame.len = rt::seq_load(s.frame_len);
    const std::uint64_t d = rt::seq_load(s.frame_data);
    for (std::size_t i = 0; i < f.frame.data.size(); ++i)
      f.frame.data[i] = static_cast<std::uint8_t>(d >> (8 * i));
    f.message.bytes = rt::seq_load(s.message_bytes);
    f.message.truncated = rt::seq_load(s.message_truncated);
    f.message.can_id = rt::seq_load(s.message_can_id);
    f.message.can_len = rt::seq_load(s.message_can_len);
    f.rated_before = rt::seq_load(s.rated_before);
    f.rated_after = rt::seq_load(s.rated_after);
    st.resetting = rt::seq_load(s.resetting);
    st.operational = rt::seq_load(s.operational);
    st.statusword = rt::seq_load(s.statusword);
    st.controlword = rt::seq_load(s.controlword);
    st.torque_permille = rt::seq_load(s.torque);
    st.counters.periods = rt::seq_load(s.periods);
    st.counters.tpdos = rt::seq_load(s.tpdos);
    st.counters.late_tpdos = rt::seq_load(s.late_tpdos);
    st.counters.short_tpdos = rt::seq_load(s.short_tpdos);
    st.counters.emcys = rt::seq_load(s.emcys);
    st.counters.error_frames = rt::seq_load(s.error_frames);
    st.counters.drive_heartbeats = rt::seq_load(s.drive_heartbeats);
    st.counters.tx_dropped = rt::seq_load(s.tx_dropped);
    st.counters.malformed_frames = rt::seq_load(s.malformed_frames);
    st.counters.malformed_messages = rt::seq_load(s.malformed_messages);
    st.counters.faults = rt::seq_load(s.faults);
  });
  st.fault_kind = f.kind;
  st.faulted = f.kind != FaultKind::none;
  st.fault_reason = describe(f, exchange_->settings());
  const auto state = cia402::decode_statusword(st.statusword);
  st.drive_state = state ? std::string(cia402::to_string(*state)) : "unknown";
  st.sdo_answers_dropped = sdo_answers_ ? sdo_answers_->dropped() : 0;
  st.rated_torque_mnm = rated_torque_mnm();
  return st;
}

// ---- lifecycle ---------------------------------------------------------------

namespace {

std::vector<CanFilter> receive_filters(const CanopenConfig& c, const CyclicMapping& m) {
  std::vector<CanFilter> filters = {exact_standard_filter(m.tpdo_position_id),
                                    exact_standard_filter(cia301::emcy_id(c.node_id)),
                                    exact_standard_filter(cia301::sdo_response_id(c.node_id)),
                                    exact_standard_filter(cia301::heartbeat_id(c.node_id))};
  if (m.tpdo_velocity) filters.push_back(exact_standard_filter(m.tpdo_velocity_id));
  return filters;
}

SetupOptions setup_options(const CanopenConfig& c, double period_s) {
  SetupOptions o;
  o.node = c.node_id;
  o.master_node = c.master_node_id;
  o.period_s = period_s;
  o.heartbeat_period_ms = static_cast<std::uint16_t>(std::llround(c.heartbeat_period * 1e3));
  o.heartbeat_timeout_ms = static_cast<std::uint16_t>(std::llround(c.heartbeat_timeout * 1e3));
  o.rated_torque_mnm = static_cast<std::uint32_t>(std::llround(c.rated_torque * 1e3));
  o.velocity = c.velocity_pdo;
  return o;
}

CyclicSettings cyclic_settings(const CanopenConfig& c, const SetupResult& setup, const Scaling& scaling,
                               double period_s) {
  CyclicSettings s;
  s.node = c.node_id;
  s.master_node = c.master_node_id;
  s.mapping = setup.mapping;
  s.scaling = scaling;
  s.tpdo_timeout_periods = c.tpdo_timeout_periods;
  // The heartbeat goes out at least as often as configured (never later).
  s.heartbeat_every_periods = static_cast<std::uint32_t>(std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::floor(c.heartbeat_period / period_s + 1e-9))));
  s.drive_heartbeat_timeout_periods = static_cast<std::uint32_t>(periods_in(c.heartbeat_timeout, period_s));
  s.reset_timeout_periods = static_cast<std::uint32_t>(periods_in(reset_timeout_s, period_s));
  return s;
}

std::chrono::microseconds sdo_timeout(const CanopenConfig& c) {
  return std::chrono::microseconds(static_cast<std::int64_t>(std::llround(c.sdo_timeout * 1e6)));
}

}  // namespace

void CanopenSession::configure(double period_s) {
  if (!(period_s > 0.0)) throw SetupError("canopen: the loop period must be > 0 s", "period");
  period_s_ = period_s;
  // The budget first: a period the bus cannot carry is refused before touching it.
  const CyclicMapping mapping = standard_mapping(config_.node_id, config_.velocity_pdo);
  budget_ = cia301::check_bus_budget(cyclic_frames(mapping), period_s, config_.bitrate);
  if (!budget_.fits) throw SetupError(budget_.summary, "bitrate");
  try {
    socket_ =
        CanSocket::open(config_.interface, receive_filters(config_, mapping), subscribed_error_classes());
  } catch (const std::runtime_error& e) {
    throw SetupError(e.what(), "interface");
  }
  try {
    SocketLink link(socket_);
    SdoClient sdo(link, config_.node_id, sdo_timeout(config_), stop_);
    setup_ = setup_drive(sdo, link, setup_options(config_, period_s));
    rated_torque_mnm_.store(setup_.rated_torque_mnm, std::memory_order_release);
    sdo_answers_ = std::make_unique<rt::SpscRing<Frame>>(sdo_ring_capacity);
    unit_changes_ = std::make_unique<rt::SpscRing<TorqueUnitChange>>(unit_ring_capacity);
    exchange_.emplace(
        cyclic_settings(config_, setup_, canopen::scaling(config_, setup_.rated_torque_mnm), period_s));
    if (!link.send(cia301::encode_nmt(cia301::NmtCommand::start, config_.node_id)))
      throw SetupError(
          "cannot send NMT start to node " + std::to_string(config_.node_id) + ": " + link.link_error(),
          "interface");
    prime();
  } catch (...) {
    exchange_.reset();
    socket_.close();
    throw;
  }
}

void CanopenSession::prime() {
  // One SYNC (with Disable Voltage in RPDO1) so the first TPDO brings the
  // position: read() is valid after configure(). No heartbeat yet: the
  // drive's consumer starts with hapticd's first heartbeat, in enable().
  const auto wait = sdo_timeout(config_);
  for (int attempt = 0; attempt < prime_attempts && !exchange_->has_position(); ++attempt) {
    std::array<Frame, 4> frames;
    const std::size_t n = exchange_->end_period(0.0, frames);
    for (std::size_t i = 0; i < n; ++i)
      if (frames[i].id != cia301::heartbeat_id(config_.master_node_id)) socket_.send(frames[i]);
    const SlicedWait deadline(stop_, wait);
    Frame f;
    while (!exchange_->has_position() && !deadline.expired()) {
      const IoStatus s = socket_.receive(f);
      if (s == IoStatus::ok) {
        exchange_->on_frame(f);
      } else if (s == IoStatus::malformed) {
        exchange_->on_malformed_message(socket_.last_malformed());
        throw SetupError("node " + std::to_string(config_.node_id) +
                             " after NMT start and SYNC: " + describe(socket_.last_malformed()),
                         "interface");
      } else if (s == IoStatus::would_block) {
        throw_if_stopped(stop_,
                         "canopen: waiting for node " + std::to_string(config_.node_id) + "'s first TPDO");
        socket_.wait_readable(std::chrono::duration_cast<std::chrono::microseconds>(deadline.next_slice()));
      } else {
        break;
      }
    }
  }
  if (!exchange_->has_position()) {
    char id[8];
    std::snprintf(id, sizeof id, "0x%03X", static_cast<unsigned>(setup_.mapping.tpdo_position_id));
    throw SetupError("node " + std::to_string(config_.node_id) + " sent no TPDO1 (" + id +
                         ") after NMT start and SYNC within " +
                         std::to_string(std::llround(config_.sdo_timeout * 1e3)) + " ms",
                     "node_id");
  }
  publish();
}

template <class Done>
bool CanopenSession::run_periods(Done&& done, std::uint64_t max_periods) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s_));
  auto next = Clock::now();
  for (std::uint64_t i = 0; i < max_periods; ++i) {
    Reading r;
    (void)read(r);
    (void)write(0.0);
    if (done()) return true;
    next += period;
    std::this_thread::sleep_until(next);
  }
  return done();
}

bool CanopenSession::loop_running(double at_least_s) const {
  const std::uint64_t before = reads_.load(std::memory_order_acquire);
  const auto wait = std::chrono::duration<double>(std::max(5 * period_s_, at_least_s));
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
  while (Clock::now() < deadline) {
    if (reads_.load(std::memory_order_acquire) != before) return true;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return false;
}

void CanopenSession::enable() {
  const std::string step = "canopen: enabling node " + std::to_string(config_.node_id);
  {
    std::lock_guard lock(sdo_mutex_);
    SocketLink link(socket_, &*exchange_);
    try {
      recheck_torque_unit(link, false);  // applied by the first read() below
    } catch (const StopRequested&) {
      throw StopRequested(abandoned(step));
    }
  }
  exchange_->set_enabled(true);
  const bool ok = run_periods(
      [this] { return stop_.stop_requested() || exchange_->operational() || exchange_->faulted(); },
      periods_in(enable_timeout_s, period_s_));
  const bool stopped = stop_.stop_requested();
  if (stopped || !ok || exchange_->faulted()) {
    const std::string why = exchange_->faulted()
                                ? describe(exchange_->fault(), exchange_->settings())
                                : "it is in " + status().drive_state + " after " +
                                      std::to_string(std::llround(enable_timeout_s * 1e3)) + " ms";
    exchange_->set_enabled(false);
    run_periods([] { return false; }, 2);  // Disable Voltage goes out
    if (stopped) throw StopRequested(abandoned(step));
    throw SetupError("node " + std::to_string(config_.node_id) + " could not be enabled: " + why, "");
  }
  enabled_.store(true, std::memory_order_release);
}

std::string CanopenSession::clear_fault() {
  const std::string step = "canopen: clearing the fault of node " + std::to_string(config_.node_id);
  const SessionStatus before = status();
  if (!before.faulted) return "";
  if (before.fault_kind == FaultKind::drive_restarted)
    throw SetupError("not cleared: " + before.fault_reason, "");
  // Which thread owns the socket decides the link: a loop this VM stalls for
  // more than 5 ms must not be taken for none (its answers would go to the
  // ring while this thread read the socket), so it gets 100 ms to show up.
  const bool loop = loop_running(clear_loop_wait_s);
  // The unit the reset resumes with: a changed 0x6076 is taken now, the
  // torque still zero. A lost link has nothing to read (the reset fails below).
  if (before.fault_kind != FaultKind::link_lost) {
    std::lock_guard lock(sdo_mutex_);
    try {
      if (loop) {
        RingLink link(socket_, *sdo_answers_);
        recheck_torque_unit(link, false);
      } else {
        SocketLink link(socket_, &*exchange_);
        recheck_torque_unit(link, false);
      }
    } catch (const SetupError& e) {
      throw SetupError("the drive stays in fault: " + before.fault_reason + "; " + e.what(), e.key());
    } catch (const StopRequested&) {
      throw StopRequested(abandoned(step));
    }
  }
  clear_requested_.store(true, std::memory_order_release);
  const auto limit = std::chrono::duration<double>(reset_timeout_s + 0.5);
  if (loop) {
    // The loop takes the request at its next read() but publishes its status
    // only at write(): until a publication after the take, status() still
    // shows the old fault, not yet resetting.
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(limit);
    std::optional<std::uint64_t> taken_before;  // publications when the take was seen
    for (;;) {
      if (!taken_before && !clear_requested_.load(std::memory_order_acquire))
        taken_before = publications_.load(std::memory_order_acquire);
      if (taken_before && publications_.load(std::memory_order_acquire) > *taken_before) {
        const SessionStatus now = status();
        if (!now.resetting && (now.operational || now.faulted)) break;
      }
      if (Clock::now() >= deadline || stop_.stop_requested()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  } else {
    run_periods(
        [this] {
          return stop_.stop_requested() ||
                 (!clear_requested_.load() && (exchange_->operational() || exchange_->faulted()));
        },
        periods_in(limit.count(), period_s_));
  }
  const SessionStatus after = status();
  if (!after.operational && stop_.stop_requested()) {
    clear_requested_.store(false, std::memory_order_release);
    throw StopRequested(abandoned(step));
  }
  if (!after.operational)
    throw SetupError(
        "the drive stays in fault: " + (after.faulted ? after.fault_reason : "it is in " + after.drive_state),
        "");
  return before.fault_reason;
}

void CanopenSession::disable() noexcept {
  if (!exchange_) return;
  try {
    disable_requested_.store(true, std::memory_order_release);
    if (loop_running()) {
      // The loop takes the request at its next read(); give the Disable Voltage a few periods to go out.
      const std::uint64_t seen = reads_.load(std::memory_order_acquire);
      const auto deadline = Clock::now() + std::chrono::milliseconds(200);
      while (Clock::now() < deadline && (disable_requested_.load(std::memory_order_acquire) ||
                                         reads_.load(std::memory_order_acquire) < seen + 3))
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    } else {
      exchange_->set_enabled(false);
      disable_requested_.store(false);
      run_periods([] { return false; }, 3);  // Disable Voltage goes out with the next SYNCs
    }
  } catch (...) {
  }
  enabled_.store(false, std::memory_order_release);
}

void CanopenSession::close() noexcept {
  if (!socket_.is_open()) return;
  if (exchange_ && enabled()) disable();
  try {
    SocketLink link(socket_);
    SdoClient sdo(link, config_.node_id, sdo_timeout(config_), stop_);
    release_drive(sdo, link, config_.node_id);
  } catch (...) {
  }
  socket_.close();
  exchange_.reset();
}

// ---- RT ----------------------------------------------------------------------

IoResult CanopenSession::read(Reading& out) noexcept {
  if (!exchange_ || !socket_.is_open()) return IoResult::error;
  reads_.fetch_add(1, std::memory_order_release);
  if (clear_requested_.exchange(false, std::memory_order_acq_rel)) {
    exchange_->set_enabled(true);
    exchange_->request_fault_reset();
  }
  if (disable_requested_.exchange(false, std::memory_order_acq_rel)) exchange_->set_enabled(false);
  apply_torque_unit();
  Frame f;
  for (int i = 0; i < max_frames_per_period; ++i) {
    const IoStatus s = socket_.receive(f);
    if (s == IoStatus::would_block) break;
    if (s == IoStatus::malformed) {
      exchange_->on_malformed_message(socket_.last_malformed());  // latched: zero output this period
      continue;
    }
    if (s != IoStatus::ok) {
      exchange_->on_link_lost(socket_.last_errno(), s == IoStatus::closed);
      break;
    }
    if (exchange_->on_frame(f) == FrameUse::sdo_response) sdo_answers_->try_push(f);
  }
  const CycleReading r = exchange_->begin_period();
  if (exchange_->faulted()) return IoResult::fault;
  if (!r.valid) return IoResult::error;
  out.position = r.position;
  out.stale = !r.fresh;
  return IoResult::ok;
}

void CanopenSession::apply_torque_unit() noexcept {
  TorqueUnitChange change;
  while (unit_changes_->try_pop(change)) {
    if (change.fault) exchange_->on_torque_unit_changed(change.before_mnm, change.after_mnm);
    if (change.after_mnm != 0) exchange_->set_force_per_permille(change.force_per_permille);
  }
}

IoResult CanopenSession::write(double force) noexcept {
  if (!exchange_ || !socket_.is_open()) return IoResult::error;
  std::array<Frame, 4> frames;
  const std::size_t n = exchange_->end_period(force, frames);
  for (std::size_t i = 0; i < n; ++i) {
    const IoStatus s = socket_.send(frames[i]);
    if (s == IoStatus::would_block) {
      exchange_->on_frame_dropped();  // TX queue full: dropped, never waited for
    } else if (s != IoStatus::ok) {
      exchange_->on_link_lost(socket_.last_errno(), s == IoStatus::closed);
      break;
    }
  }
  publish();
  return exchange_->faulted() ? IoResult::fault : IoResult::ok;
}

// ---- commissioning -----------------------------------------------------------

SdoAccess CanopenSession::access(cia301::ObjectAddress address, std::uint32_t raw,
                                 std::optional<cia301::DataType> type) const {
  SdoAccess a;
  a.address = address;
  a.raw = raw;
  const auto info = cia402::find_standard_object(address);
  a.type = type ? type : info ? std::optional(info->type) : std::nullopt;
  a.value = a.type ? cia301::from_raw(*a.type, raw) : static_cast<std::int64_t>(raw);
  a.name = info ? std::string(info->name) : "";
  return a;
}

std::string CanopenSession::recheck_torque_unit(FrameLink& link, bool fault_if_changed) {
  if (!setup_.rated_torque_from_drive) return "";  // no 0x6076: the config's rated_torque stands
  SdoClient sdo(link, config_.node_id, sdo_timeout(config_), stop_);  // gives way to SIGTERM
  const std::uint32_t before = rated_torque_mnm();
  TorqueUnitChange change;
  change.before_mnm = before;
  change.fault = fault_if_changed;
  std::string problem;
  try {
    const auto drive = read_rated_torque(sdo);
    change.after_mnm = torque_unit(
        drive, static_cast<std::uint32_t>(std::llround(config_.rated_torque * 1e3)), config_.node_id);
  } catch (const SdoError& e) {
    problem = std::string(
                  "cannot read back 0x6076 motor rated torque, the unit of every torque hapticd "
                  "sends: ") +
              e.what();
  } catch (const SetupError& e) {
    problem = e.what();
  }
  if (!problem.empty() && !fault_if_changed) throw SetupError(problem, "rated_torque");
  if (problem.empty() && change.after_mnm == before) return "";
  if (problem.empty())
    change.force_per_permille = canopen::scaling(config_, change.after_mnm).force_per_permille;
  else
    change.after_mnm = 0;  // enabled and unreadable: a fault, the scale unchanged
  if (!unit_changes_->try_push(change))
    throw SetupError("the loop has not taken the last torque unit yet", "");
  if (!problem.empty()) throw SetupError(problem + ": torque held at zero (fault latched)", "rated_torque");
  rated_torque_mnm_.store(change.after_mnm, std::memory_order_release);
  return "node " + std::to_string(config_.node_id) + "'s 0x6076 motor rated torque is now " +
         std::to_string(change.after_mnm) + " mN m (was " + std::to_string(before) +
         "): hapticd scales every torque by it" +
         (fault_if_changed ? "; the drive was enabled: torque held at zero (fault latched) until fault clear"
                           : " from now on");
}

SdoAccess CanopenSession::sdo_read(cia301::ObjectAddress address, std::optional<cia301::DataType> type) {
  if (!exchange_) throw std::invalid_argument("the drive is not configured");
  std::lock_guard lock(sdo_mutex_);
  const auto timeout = sdo_timeout(config_);
  std::uint32_t raw = 0;
  if (enabled()) {
    RingLink link(socket_, *sdo_answers_);
    SdoClient sdo(link, config_.node_id, timeout, stop_);
    raw = sdo.read(address);
  } else {
    SocketLink link(socket_, &*exchange_);
    SdoClient sdo(link, config_.node_id, timeout, stop_);
    raw = sdo.read(address);
  }
  return access(address, raw, type);
}

SdoAccess CanopenSession::sdo_write(cia301::ObjectAddress address, std::int64_t value,
                                    std::optional<cia301::DataType> type) {
  if (!exchange_) throw std::invalid_argument("the drive is not configured");
  if (enabled()) {
    if (const auto why = refused_while_enabled(address)) throw std::invalid_argument(*why);
  }
  const cia301::DataType t = write_type(address, type);
  const auto raw = cia301::to_raw(t, value);
  if (!raw)
    throw std::invalid_argument(std::to_string(value) + " does not fit " +
                                std::string(cia301::short_name(t)) + " (" + cia301::to_string(address) + ")");
  std::lock_guard lock(sdo_mutex_);
  const bool was_enabled = enabled();
  std::optional<RingLink> ring;
  std::optional<SocketLink> direct;
  FrameLink& link = was_enabled ? static_cast<FrameLink&>(ring.emplace(socket_, *sdo_answers_))
                                : static_cast<FrameLink&>(direct.emplace(socket_, &*exchange_));
  SdoClient sdo(link, config_.node_id, sdo_timeout(config_), stop_);
  // Any write may change 0x6076 (a restore, a manufacturer's motor object):
  // it is read back after each, also after an abort (the drive may have
  // taken part of it).
  try {
    sdo.write(address, *raw, cia301::size_of(t));
  } catch (const SdoError& e) {
    std::string note;
    try {
      note = recheck_torque_unit(link, was_enabled);
    } catch (const SetupError& unreadable) {
      throw SetupError(std::string(e.what()) + "; " + unreadable.what(), unreadable.key());
    }
    if (note.empty()) throw;
    throw SdoError(std::string(e.what()) + "; " + note, e.outcome());
  }
  SdoAccess a = access(address, *raw, t);
  a.note = recheck_torque_unit(link, was_enabled);
  return a;
}

}  // namespace hapticd::drivers::canopen
