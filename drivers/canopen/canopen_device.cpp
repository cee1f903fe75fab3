#include "drivers/canopen/canopen_device.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <thread>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/device_settings.hpp"
#include "drivers/canopen/frame_links.hpp"
#include "drivers/canopen/loop_handover.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using cia301::Frame;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::size_t sdo_ring_capacity = 64;
constexpr std::size_t unit_ring_capacity = 8;

}  // namespace

CanopenDevice::CanopenDevice(CanopenConfig config) : config_(std::move(config)) { validate(config_); }

CanopenDevice::~CanopenDevice() = default;

std::chrono::microseconds CanopenDevice::sdo_timeout() const {
  return std::chrono::microseconds(static_cast<std::int64_t>(std::llround(config_.sdo_timeout * 1e6)));
}

// ---- non-RT lifecycle ------------------------------------------------------

void CanopenDevice::configure(const LoopContext& loop) {
  stop_ = loop.stop;
  homing_.reset();
  clear_requested_.store(false, std::memory_order_relaxed);
  disable_requested_.store(false, std::memory_order_relaxed);
  if (!(loop.period_s > 0.0)) throw SetupError("canopen: the loop period must be > 0 s", "period");
  period_s_ = loop.period_s;
  // The budget first: a period the bus cannot carry is refused before touching it.
  const CyclicMapping mapping = standard_mapping(config_.node_id, config_.velocity_pdo);
  budget_ = cia301::check_bus_budget(cyclic_frames(mapping), period_s_, config_.bitrate);
  if (!budget_.fits) throw SetupError(budget_.summary, "bitrate");
  try {
    socket_ =
        CanSocket::open(config_.interface, receive_filters(config_, mapping), subscribed_error_classes());
  } catch (const std::runtime_error& e) {
    throw SetupError(e.what(), "interface");
  }
  try {
    SocketLink link(socket_);
    SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
    setup_ = setup_drive(sdo, link, setup_options(config_, period_s_));
    rated_torque_mnm_.store(setup_.rated_torque_mnm, std::memory_order_release);
    sdo_answers_ = std::make_unique<rt::SpscRing<Frame>>(sdo_ring_capacity);
    unit_changes_ = std::make_unique<rt::SpscRing<TorqueUnitChange>>(unit_ring_capacity);
    exchange_.emplace(
        cyclic_settings(config_, setup_, canopen::scaling(config_, setup_.rated_torque_mnm), period_s_));
    published_.publish(*exchange_);  // no figure of an earlier configure() stays
    if (!link.send(cia301::encode_nmt(cia301::NmtCommand::start, config_.node_id)))
      throw SetupError(
          "cannot send NMT start to node " + std::to_string(config_.node_id) + ": " + link.link_error(),
          "interface");
    prime();
  } catch (...) {
    // A drive this did not finish setting up is not released by close(),
    // which the framework calls next: it only closes the socket.
    exchange_.reset();
    throw;
  }
}

void CanopenDevice::prime() {
  // One SYNC (with Disable Voltage in RPDO1) so the first TPDO brings the
  // position: read() is valid after configure(). No heartbeat yet: the
  // drive's consumer starts with hapticd's first heartbeat, in enable().
  const auto wait = sdo_timeout();
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
  published_.publish(*exchange_);
}

template <class Done>
bool CanopenDevice::run_periods(Done&& done, std::uint64_t max_periods) {
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

bool CanopenDevice::loop_running(double at_least_s) const {
  const std::uint64_t before = reads_.load(std::memory_order_acquire);
  const auto wait = std::chrono::duration<double>(std::max(5 * period_s_, at_least_s));
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
  while (Clock::now() < deadline) {
    if (reads_.load(std::memory_order_acquire) != before) return true;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return false;
}

void CanopenDevice::with_sdo_link(bool loop_owns_socket, const std::function<void(FrameLink&)>& use) {
  if (loop_owns_socket) {
    RingLink link(socket_, *sdo_answers_);
    use(link);
  } else {
    SocketLink link(socket_, &*exchange_);
    use(link);
  }
}

void CanopenDevice::enable() {
  const std::string step = "canopen: enabling node " + std::to_string(config_.node_id);
  {
    std::lock_guard lock(sdo_mutex_);
    try {
      // Applied by the first read() below.
      with_sdo_link(false, [this](FrameLink& link) { recheck_torque_unit(link, false); });
    } catch (const StopRequested&) {
      throw StopRequested(abandoned(step));
    }
  }
  if (config_.homing && !homing_) run_homing();
  exchange_->set_enabled(true);
  const bool ok = run_periods(
      [this] { return stop_.stop_requested() || exchange_->operational() || exchange_->faulted(); },
      periods_in(enable_timeout_s, period_s_));
  const bool stopped = stop_.stop_requested();
  if (stopped || !ok || exchange_->faulted()) {
    const std::string why = exchange_->faulted()
                                ? describe(exchange_->fault(), exchange_->settings())
                                : "it is in " + exchange_status().drive_state + " after " +
                                      std::to_string(std::llround(enable_timeout_s * 1e3)) + " ms";
    exchange_->set_enabled(false);
    run_periods([] { return false; }, 2);  // Disable Voltage goes out
    if (stopped) throw StopRequested(abandoned(step));
    throw SetupError("node " + std::to_string(config_.node_id) + " could not be enabled: " + why, "");
  }
  enabled_.store(true, std::memory_order_release);
}

void CanopenDevice::run_homing() {
  const std::string step = "canopen: homing node " + std::to_string(config_.node_id);
  const HomingSettings settings = homing_settings(config_);
  {
    std::lock_guard lock(sdo_mutex_);
    try {
      with_sdo_link(false, [&](FrameLink& link) {
        SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
        prepare_homing(sdo, settings, setup_.notes);
      });
    } catch (const StopRequested&) {
      throw StopRequested(abandoned(step));
    }
  }
  HomingSequence sequence(periods_in(enable_timeout_s, period_s_), periods_in(settings.timeout_s, period_s_));
  double home = 0.0;
  exchange_->set_enabled(true);
  drive_homing(sequence, home);
  exchange_->set_homing_start(false);
  exchange_->set_enabled(false);
  run_periods([] { return false; }, 2);  // Disable Voltage, bit 4 low
  if (stop_.stop_requested()) throw StopRequested(abandoned(step));
  if (sequence.phase() != HomingPhase::completed) {
    HomingVerdict verdict = describe(sequence, config_.node_id, settings.method, period_s_);
    if (exchange_->faulted()) verdict.text += ": " + describe(exchange_->fault(), exchange_->settings());
    throw SetupError(verdict.text, verdict.key);
  }
  {
    std::lock_guard lock(sdo_mutex_);
    with_sdo_link(false, [&](FrameLink& link) {
      SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
      select_mode(sdo, cia402::Mode::cyclic_synchronous_torque, "homing");
    });
  }
  homing_ = DeviceHoming{settings.method,
                         "CiA 402 homing method " + std::to_string(settings.method) + " (" +
                             std::string(cia402::describe_homing_method(settings.method)) + ")",
                         static_cast<double>(sequence.homing_periods()) * period_s_,
                         sequence.homing_periods(), home};
}

void CanopenDevice::drive_homing(HomingSequence& sequence, double& last_position) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s_));
  auto next = Clock::now();
  // Bounded by the sequence's own limits (enable, then homing_timeout), and cut by a stop.
  while (!sequence.done() && !stop_.stop_requested()) {
    Reading r;
    if (read(r) == IoResult::ok) last_position = r.position;
    sequence.step({exchange_->operational(), exchange_->faulted(), exchange_->statusword(),
                   exchange_->counters().tpdos});
    exchange_->set_homing_start(sequence.start_bit());
    (void)write(0.0);
    next += period;
    std::this_thread::sleep_until(next);
  }
}

std::string CanopenDevice::clear_fault() {
  const std::string step = "canopen: clearing the fault of node " + std::to_string(config_.node_id);
  const ExchangeStatus before = exchange_status();
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
      with_sdo_link(loop, [this](FrameLink& link) { recheck_torque_unit(link, false); });
    } catch (const SetupError& e) {
      throw SetupError("the drive stays in fault: " + before.fault_reason + "; " + e.what(), e.key());
    } catch (const StopRequested&) {
      throw StopRequested(abandoned(step));
    }
  }
  clear_requested_.store(true, std::memory_order_release);
  if (loop) {
    await_reset_by_loop();
  } else {
    run_periods(
        [this] {
          return stop_.stop_requested() ||
                 (!clear_requested_.load() && (exchange_->operational() || exchange_->faulted()));
        },
        periods_in(reset_timeout_s + 0.5, period_s_));
  }
  const ExchangeStatus after = exchange_status();
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

void CanopenDevice::await_reset_by_loop() const {
  // The loop takes the request at its next read() but publishes its status
  // only at write(): until a publication after the take, the status still
  // shows the old fault, not yet resetting.
  const auto limit = std::chrono::duration<double>(reset_timeout_s + 0.5);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(limit);
  std::optional<std::uint64_t> taken_before;  // publications when the take was seen
  for (;;) {
    if (!taken_before && !clear_requested_.load(std::memory_order_acquire))
      taken_before = published_.publications();
    if (taken_before && published_.publications() > *taken_before) {
      const ExchangeStatus now = exchange_status();
      if (!now.resetting && (now.operational || now.faulted)) return;
    }
    if (Clock::now() >= deadline || stop_.stop_requested()) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void CanopenDevice::disable() noexcept {
  try {
    disable_requested_.store(true, std::memory_order_release);
    if (loop_running()) {
      // The loop takes the request at its next read(); give the Disable Voltage a few periods to go out.
      await_loop_handover(disable_requested_, reads_);
    } else {
      exchange_->set_enabled(false);
      disable_requested_.store(false);
      run_periods([] { return false; }, 3);  // Disable Voltage goes out with the next SYNCs
    }
  } catch (...) {
  }
  enabled_.store(false, std::memory_order_release);
}

void CanopenDevice::close() noexcept {
  if (exchange_) {
    try {
      SocketLink link(socket_);
      SdoClient sdo(link, config_.node_id, sdo_timeout(), stop_);
      release_drive(sdo, link, config_.node_id);
    } catch (...) {
    }
  }
  socket_.close();
  exchange_.reset();
}

// ---- RT ----------------------------------------------------------------------

IoResult CanopenDevice::read(Reading& out) noexcept {
  reads_.fetch_add(1, std::memory_order_release);
  if (clear_requested_.exchange(false, std::memory_order_acq_rel)) {
    exchange_->set_enabled(true);
    exchange_->request_fault_reset();
  }
  if (disable_requested_.exchange(false, std::memory_order_acq_rel)) exchange_->set_enabled(false);
  apply_torque_unit();
  drain_socket();
  const CycleReading r = exchange_->begin_period();
  if (exchange_->faulted()) return IoResult::fault;
  if (!r.valid) return IoResult::error;
  out.position = r.position;
  out.stale = !r.fresh;
  return IoResult::ok;
}

void CanopenDevice::drain_socket() noexcept {
  Frame f;
  for (int i = 0; i < max_frames_per_period; ++i) {
    const IoStatus s = socket_.receive(f);
    if (s == IoStatus::would_block) return;
    if (s == IoStatus::malformed) {
      exchange_->on_malformed_message(socket_.last_malformed());  // latched: zero output this period
      continue;
    }
    if (s != IoStatus::ok) {
      exchange_->on_link_lost(socket_.last_errno(), s == IoStatus::closed);
      return;
    }
    if (exchange_->on_frame(f) == FrameUse::sdo_response) sdo_answers_->try_push(f);
  }
}

void CanopenDevice::apply_torque_unit() noexcept {
  TorqueUnitChange change;
  while (unit_changes_->try_pop(change)) {
    if (change.fault) exchange_->on_torque_unit_changed(change.before_mnm, change.after_mnm);
    if (change.after_mnm != 0) exchange_->set_force_per_permille(change.force_per_permille);
  }
}

IoResult CanopenDevice::write(double force) noexcept {
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
  published_.publish(*exchange_);
  return exchange_->faulted() ? IoResult::fault : IoResult::ok;
}

// ---- any non-RT thread -------------------------------------------------------

DeviceModel CanopenDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  const double unit = config_.motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  m.position_resolution = unit / config_.counts_per_unit;
  m.delay_periods = 1;  // the RPDO sent before SYNC n acts at SYNC n; the position is from SYNC n-1
  m.source = "config";
  const DriveIdentity& id = setup_.identity;
  m.description = "CiA 402 drive, node " + std::to_string(config_.node_id) + " (vendor " +
                  world::text::format_hex(id.vendor_id, 8) + ", product " +
                  world::text::format_hex(id.product_code, 8) + "), cyclic synchronous torque";
  for (const std::string& note : setup_.notes) m.description += "; " + note;
  return m;
}

std::string CanopenDevice::identity() const {
  const DriveIdentity& id = setup_.identity;
  using world::text::format_hex;
  return "interface " + config_.interface + ", node " + std::to_string(config_.node_id) + ", vendor " +
         format_hex(id.vendor_id, 8) + ", product " + format_hex(id.product_code, 8) + ", revision " +
         format_hex(id.revision, 8) + ", serial " + format_hex(id.serial, 8);
}

ExchangeStatus CanopenDevice::exchange_status() const {
  if (!exchange_) return {};
  return published_.load(exchange_->settings());
}

DeviceHealth CanopenDevice::health() const {
  DeviceHealth h;
  if (!exchange_) return h;
  const ExchangeStatus st = exchange_status();
  h.faulted = st.faulted;
  h.fault_reason = st.fault_reason;
  const CyclicCounters& c = st.counters;
  h.counters = {{"periods", c.periods},
                {"tpdos", c.tpdos},
                {"late_tpdos", c.late_tpdos},
                {"short_tpdos", c.short_tpdos},
                {"emcys", c.emcys},
                {"error_frames", c.error_frames},
                {"drive_heartbeats", c.drive_heartbeats},
                {"tx_dropped", c.tx_dropped},
                {"malformed_frames", c.malformed_frames},
                {"malformed_messages", c.malformed_messages},
                {"sdo_answers_dropped", sdo_answers_->dropped()},
                {"rated_torque_mnm", rated_torque_mnm()},
                {"statusword", st.statusword},
                {"controlword", st.controlword}};
  return h;
}

}  // namespace hapticd::drivers::canopen
