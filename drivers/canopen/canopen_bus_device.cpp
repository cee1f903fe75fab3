#include "drivers/canopen/canopen_bus_device.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <thread>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/canopen_device.hpp"
#include "drivers/canopen/device_settings.hpp"
#include "drivers/canopen/frame_links.hpp"
#include "drivers/canopen/loop_handover.hpp"
#include "rt/spsc_ring.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using cia301::Frame;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::size_t node_sdo_ring_capacity = 64;  // answers of one transfer at a time, and late ones
constexpr std::size_t node_unit_ring_capacity = 4;  // one change per write, taken the next period

std::string node_list_words(std::span<const std::uint8_t> nodes) {
  std::string out;
  for (const std::uint8_t n : nodes) out += (out.empty() ? "" : ", ") + std::to_string(n);
  return out;
}

}  // namespace

cia301::BusBudget bus_budget_for_nodes(std::span<const CyclicMapping> mappings,
                                       std::span<const std::uint8_t> nodes, double period_s,
                                       std::uint32_t bitrate) {
  // One SYNC for all (CiA 301: one SYNC producer), then each node's PDOs.
  std::vector<cia301::CyclicFrame> frames = {{"SYNC", 0}};
  for (const CyclicMapping& m : mappings) {
    const auto own = cyclic_frames(m);
    frames.insert(frames.end(), own.begin() + 1, own.end());  // its own frames, not its SYNC
  }
  cia301::BusBudget budget = cia301::check_bus_budget(frames, period_s, bitrate);
  budget.summary = std::to_string(nodes.size()) + " drives on one bus (nodes " + node_list_words(nodes) +
                   ", one SYNC): " + budget.summary;
  return budget;
}

struct CanopenBusDevice::Node {
  CanopenConfig config;  ///< this axis' settings (axis_config)
  CyclicMapping mapping;
  SetupResult setup;
  std::optional<CyclicExchange> exchange;
  PublishedExchange published;
  /// The loop's read_axes() -> this node's SDO client (commissioning).
  rt::SpscRing<cia301::Frame> sdo_answers{node_sdo_ring_capacity};
  /// A commissioning write's new 0x6076 -> the loop's read_axes().
  rt::SpscRing<TorqueUnitChange> unit_changes{node_unit_ring_capacity};
  std::atomic<std::uint32_t> rated_torque_mnm{0};  ///< the unit of this node's 0x6071, as the loop uses it
};

/// Each node's SDO client in turn, on one link over the bus socket (non-RT).
template <class Use>
void CanopenBusDevice::with_each_node_sdo(Use&& use) {
  SocketLink link(socket_);
  for (auto& node : nodes_) {
    SdoClient sdo(link, node->config.node_id, sdo_timeout(), stop_);
    use(*node, sdo, link);
  }
}

std::chrono::microseconds CanopenBusDevice::sdo_timeout() const {
  return std::chrono::microseconds(static_cast<std::int64_t>(std::llround(config_.sdo_timeout * 1e6)));
}

std::size_t CanopenBusDevice::axis_of_node(std::uint8_t node_id) const {
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (nodes_[i]->config.node_id == node_id) return i;
  throw std::invalid_argument("node " + std::to_string(node_id) +
                              " is not one of this device's drives; accepted: node_ids " +
                              node_list_words(config_.node_ids));
}

template <class Use>
auto CanopenBusDevice::with_node_sdo(std::size_t axis, Use&& use) {
  // The loop owns the socket's receive side: the answer comes through it (sdo_mutex_ held).
  if (!loop_running())
    throw std::invalid_argument(
        "the loop is not running: with several drives an SDO transfer goes through it");
  Node& node = *nodes_[axis];
  RingLink link(socket_, node.sdo_answers);
  SdoClient sdo(link, node.config.node_id, sdo_timeout(), stop_);
  return use(node, sdo);
}

SdoAccess CanopenBusDevice::sdo_read(std::uint8_t node_id, cia301::ObjectAddress address,
                                     std::optional<cia301::DataType> type) {
  const std::size_t axis = axis_of_node(node_id);
  std::lock_guard lock(sdo_mutex_);
  const std::uint32_t raw = with_node_sdo(axis, [&](Node&, SdoClient& sdo) { return sdo.read(address); });
  return describe_access(address, raw, type);
}

SdoAccess CanopenBusDevice::sdo_write(std::uint8_t node_id, cia301::ObjectAddress address, std::int64_t value,
                                      std::optional<cia301::DataType> type) {
  const std::size_t axis = axis_of_node(node_id);
  const bool was_enabled = enabled_.load(std::memory_order_acquire);
  const CheckedWrite write = checked_write(address, value, type, was_enabled);
  std::lock_guard lock(sdo_mutex_);
  SdoAccess a = describe_access(address, write.raw, write.type);
  with_node_sdo(axis, [&](Node& node, SdoClient& sdo) {
    a.note = write_and_recheck(sdo, address, write,
                               [&] { return recheck_torque_unit(axis, node, sdo, was_enabled); });
  });
  return a;
}

std::string CanopenBusDevice::recheck_torque_unit(std::size_t axis, Node& node, SdoClient& sdo,
                                                  bool fault_if_changed) {
  if (!node.setup.rated_torque_from_drive) return "";  // no 0x6076: the config's rated_torque stands
  const TorqueUnitCheck check = check_torque_unit(
      sdo, node.config, node.rated_torque_mnm.load(std::memory_order_acquire), fault_if_changed);
  if (!check.change) return "";
  if (!node.unit_changes.try_push(*check.change))
    throw SetupError("the loop has not taken the last torque unit yet", "");
  if (!check.problem.empty())
    throw SetupError(check.problem + ": every axis held at zero (fault latched)", "rated_torque");
  node.rated_torque_mnm.store(check.change->after_mnm, std::memory_order_release);
  return torque_unit_note(node.config.node_id, *check.change,
                          "axis " + std::to_string(axis + 1) + "'s torque",
                          "the drives were enabled: every axis held at zero");
}

CanopenBusDevice::CanopenBusDevice(CanopenConfig config) : config_(std::move(config)) {
  validate(config_);
  if (config_.node_ids.size() < 2)
    throw ConfigError("node_ids must name 2 or more drives for several axes", "node_ids");
  for (std::size_t i = 0; i < config_.node_ids.size(); ++i) {
    auto node = std::make_unique<Node>();
    node->config = axis_config(config_, i);
    node->mapping = standard_mapping(node->config.node_id, config_.velocity_pdo);
    nodes_.push_back(std::move(node));
  }
}

CanopenBusDevice::~CanopenBusDevice() = default;

// ---- non-RT lifecycle ------------------------------------------------------

void CanopenBusDevice::configure(const LoopContext& loop) {
  stop_ = loop.stop;
  configured_ = false;
  homing_.reset();
  clear_requested_.store(false, std::memory_order_relaxed);
  disable_requested_.store(false, std::memory_order_relaxed);
  if (!(loop.period_s > 0.0)) throw SetupError("canopen: the loop period must be > 0 s", "period");
  period_s_ = loop.period_s;
  // The budget of every node first: a period the bus cannot carry is refused before touching it.
  std::vector<CyclicMapping> mappings;
  std::vector<CanFilter> filters;
  for (const auto& node : nodes_) {
    mappings.push_back(node->mapping);
    const auto own = receive_filters(node->config, node->mapping);
    filters.insert(filters.end(), own.begin(), own.end());
  }
  budget_ = bus_budget_for_nodes(mappings, config_.node_ids, period_s_, config_.bitrate);
  if (!budget_.fits) throw SetupError(budget_.summary, "bitrate");
  try {
    socket_ = CanSocket::open(config_.interface, filters, subscribed_error_classes());
  } catch (const std::runtime_error& e) {
    throw SetupError(e.what(), "interface");
  }
  try {
    with_each_node_sdo([this](Node& node, SdoClient& sdo, SocketLink& link) {
      node.setup = setup_drive(sdo, link, setup_options(node.config, period_s_));
    });
    SocketLink link(socket_);
    for (auto& node : nodes_) {
      node->exchange.emplace(cyclic_settings(node->config, node->setup,
                                             scaling(node->config, node->setup.rated_torque_mnm), period_s_));
      node->rated_torque_mnm.store(node->setup.rated_torque_mnm, std::memory_order_release);
      node->published.publish(*node->exchange);
      if (!link.send(cia301::encode_nmt(cia301::NmtCommand::start, node->config.node_id)))
        throw SetupError("cannot send NMT start to node " + std::to_string(node->config.node_id) + ": " +
                             link.link_error(),
                         "interface");
    }
    prime();
  } catch (...) {
    for (auto& node : nodes_) node->exchange.reset();
    throw;
  }
  configured_ = true;
}

void CanopenBusDevice::prime() {
  // One SYNC (every node's RPDO1 with Disable Voltage first): each node's
  // first TPDO1 brings its position. No heartbeat yet (enable() sends it).
  const auto wait =
      std::chrono::microseconds(static_cast<std::int64_t>(std::llround(config_.sdo_timeout * 1e6)));
  const auto primed = [this] { return all(&CyclicExchange::has_position); };
  for (int attempt = 0; attempt < prime_attempts && !primed(); ++attempt) {
    for (auto& node : nodes_) {
      std::array<Frame, 4> frames;
      const std::size_t n = node->exchange->end_period(0.0, frames);
      for (std::size_t i = 0; i < n; ++i)
        if (frames[i].id != cia301::cob::sync && frames[i].id != cia301::heartbeat_id(config_.master_node_id))
          socket_.send(frames[i]);
    }
    socket_.send(cia301::encode_sync());
    const SlicedWait deadline(stop_, wait);
    while (!primed() && !deadline.expired()) {
      Frame f;
      const IoStatus s = socket_.receive(f);
      if (s == IoStatus::ok) {
        for (auto& node : nodes_) node->exchange->on_frame(f);
      } else if (s == IoStatus::malformed) {
        throw SetupError("after NMT start and SYNC: " + describe(socket_.last_malformed()), "interface");
      } else if (s == IoStatus::would_block) {
        throw_if_stopped(stop_, "canopen: waiting for the drives' first TPDOs");
        socket_.wait_readable(std::chrono::duration_cast<std::chrono::microseconds>(deadline.next_slice()));
      } else {
        break;
      }
    }
  }
  for (const auto& node : nodes_) {
    if (!node->exchange->has_position())
      throw SetupError("node " + std::to_string(node->config.node_id) + " sent no TPDO1 (" +
                           world::text::format_hex(node->mapping.tpdo_position_id, 3) +
                           ") after NMT start and SYNC within " +
                           std::to_string(std::llround(config_.sdo_timeout * 1e3)) + " ms",
                       "node_ids");
  }
  publish_all();
}

template <class Done>
bool CanopenBusDevice::run_periods(Done&& done, std::uint64_t max_periods) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s_));
  auto next = Clock::now();
  std::array<Reading, max_axes> readings;
  const std::array<double, max_axes> zero{};
  for (std::uint64_t i = 0; i < max_periods; ++i) {
    (void)read_axes(std::span<Reading>(readings.data(), nodes_.size()));
    (void)write_axes(std::span<const double>(zero.data(), nodes_.size()));
    if (done()) return true;
    next += period;
    std::this_thread::sleep_until(next);
  }
  return done();
}

bool CanopenBusDevice::all(bool (CyclicExchange::*test)() const noexcept) const {
  return std::all_of(nodes_.begin(), nodes_.end(), [&](const auto& n) { return ((*n->exchange).*test)(); });
}

bool CanopenBusDevice::any(bool (CyclicExchange::*test)() const noexcept) const {
  return std::any_of(nodes_.begin(), nodes_.end(), [&](const auto& n) { return ((*n->exchange).*test)(); });
}

void CanopenBusDevice::run_homing() {
  const std::string step = "canopen: homing nodes " + node_list_words(config_.node_ids);
  const HomingSettings settings = homing_settings(config_);
  try {
    std::size_t axis = 0;
    with_each_node_sdo([&](Node& node, SdoClient& sdo, SocketLink&) {
      ++axis;
      try {
        prepare_homing(sdo, homing_settings(node.config), node.setup.notes);
      } catch (const SetupError& e) {
        throw SetupError("axis " + std::to_string(axis) + ": " + e.what(), homing_key(e.key()));
      }
    });
  } catch (const StopRequested&) {
    throw StopRequested(abandoned(step));
  }
  std::vector<HomingSequence> sequences(
      nodes_.size(),
      HomingSequence(periods_in(enable_timeout_s, period_s_), periods_in(settings.timeout_s, period_s_)));
  for (auto& node : nodes_) node->exchange->set_enabled(true);
  double home = 0.0;
  drive_homing(sequences, home);
  for (auto& node : nodes_) {
    node->exchange->set_homing_start(false);
    node->exchange->set_enabled(false);
  }
  run_periods([] { return false; }, 2);  // Disable Voltage, bit 4 low
  if (stop_.stop_requested()) throw StopRequested(abandoned(step));
  std::uint64_t longest = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& node = *nodes_[i];
    longest = std::max(longest, sequences[i].homing_periods());
    if (sequences[i].phase() == HomingPhase::completed) continue;
    HomingVerdict verdict = describe(sequences[i], node.config.node_id,
                                     static_cast<std::int8_t>(node.config.homing_method), period_s_);
    if (node.exchange->faulted())
      verdict.text += ": " + describe(node.exchange->fault(), node.exchange->settings());
    throw SetupError("axis " + std::to_string(i + 1) + ": " + verdict.text, homing_key(verdict.key));
  }
  with_each_node_sdo([](Node&, SdoClient& sdo, SocketLink&) {
    select_mode(sdo, cia402::Mode::cyclic_synchronous_torque, "homing");
  });
  homing_ = DeviceHoming{nodes_.front()->config.homing_method, homing_words(),
                         static_cast<double>(longest) * period_s_, longest, home};
}

std::string CanopenBusDevice::homing_key(const std::string& key) const {
  const bool own = (key == "homing_method" && !config_.axis_homing_method.empty()) ||
                   (key == "home_offset" && !config_.axis_home_offset.empty());
  return own ? "axis_" + key : key;
}

std::string CanopenBusDevice::homing_words() const {
  const auto method_words = [](int method) {
    return "method " + std::to_string(method) + " (" +
           std::string(cia402::describe_homing_method(static_cast<std::int8_t>(method))) + ")";
  };
  if (config_.axis_homing_method.empty())
    return "CiA 402 homing " + method_words(config_.homing_method) + " on nodes " +
           node_list_words(config_.node_ids);
  std::string words = "CiA 402 homing";
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    words += std::string(i ? ", node " : ": node ") + std::to_string(nodes_[i]->config.node_id) + " " +
             method_words(nodes_[i]->config.homing_method);
  return words;
}

void CanopenBusDevice::drive_homing(std::vector<HomingSequence>& sequences, double& home) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period_s_));
  auto next = Clock::now();
  std::array<Reading, max_axes> readings;
  const std::array<double, max_axes> zero{};
  const auto finished = [&] {
    const bool failed = std::any_of(sequences.begin(), sequences.end(),
                                    [](const auto& s) { return s.phase() == HomingPhase::failed; });
    return failed || std::all_of(sequences.begin(), sequences.end(), [](const auto& s) { return s.done(); });
  };
  // Every node in the same periods, one SYNC for all; bounded by each
  // sequence's own limits (enable, then homing_timeout), cut by a stop or
  // by the first node that fails.
  while (!finished() && !stop_.stop_requested()) {
    if (read_axes(std::span<Reading>(readings.data(), nodes_.size())) == IoResult::ok)
      home = readings[0].position;
    for (std::size_t i = 0; i < nodes_.size(); ++i) {
      CyclicExchange& x = *nodes_[i]->exchange;
      if (!sequences[i].done())
        sequences[i].step({x.operational(), x.faulted(), x.statusword(), x.counters().tpdos});
      x.set_homing_start(sequences[i].start_bit());
    }
    (void)write_axes(std::span<const double>(zero.data(), nodes_.size()));
    next += period;
    std::this_thread::sleep_until(next);
  }
}

void CanopenBusDevice::enable() {
  if (config_.homing && !homing_) run_homing();
  for (auto& node : nodes_) node->exchange->set_enabled(true);
  const bool ok = run_periods(
      [this] {
        return stop_.stop_requested() || all(&CyclicExchange::operational) || any(&CyclicExchange::faulted);
      },
      periods_in(enable_timeout_s, period_s_));
  const bool stopped = stop_.stop_requested();
  if (stopped || !ok || any(&CyclicExchange::faulted)) {
    std::string why = fault_words();
    for (std::size_t i = 0; why.empty() && i < nodes_.size(); ++i) {
      if (!nodes_[i]->exchange->operational())
        why = "axis " + std::to_string(i + 1) + " (node " + std::to_string(nodes_[i]->config.node_id) +
              ") is in " + exchange_status(i).drive_state + " after " +
              std::to_string(std::llround(enable_timeout_s * 1e3)) + " ms";
    }
    for (auto& node : nodes_) node->exchange->set_enabled(false);
    run_periods([] { return false; }, 2);  // Disable Voltage goes out
    if (stopped)
      throw StopRequested(abandoned("canopen: enabling nodes " + node_list_words(config_.node_ids)));
    throw SetupError("the drives could not be enabled: " + why, "");
  }
  enabled_.store(true, std::memory_order_release);
}

std::string CanopenBusDevice::clear_fault() {
  std::string before = fault_words();
  if (before.empty()) return "";
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (exchange_status(i).fault_kind == FaultKind::drive_restarted)
      throw SetupError("not cleared: " + before, "");
  const bool loop = loop_running();
  clear_requested_.store(true, std::memory_order_release);
  if (loop) {
    await_reset_by_loop();
  } else {
    run_periods(
        [this] {
          return stop_.stop_requested() || (!clear_requested_.load() && (all(&CyclicExchange::operational) ||
                                                                         any(&CyclicExchange::faulted)));
        },
        periods_in(reset_timeout_s + 0.5, period_s_));
  }
  bool operational = true;
  for (std::size_t i = 0; i < nodes_.size(); ++i) operational = operational && exchange_status(i).operational;
  if (!operational && stop_.stop_requested()) {
    clear_requested_.store(false, std::memory_order_release);
    throw StopRequested(
        abandoned("canopen: clearing the fault of nodes " + node_list_words(config_.node_ids)));
  }
  if (!operational) {
    const std::string now = fault_words();
    throw SetupError(
        "the drives stay in fault: " + (now.empty() ? "not every node is in Operation Enabled" : now), "");
  }
  return before;
}

bool CanopenBusDevice::loop_running() const {
  const std::uint64_t before = reads_.load(std::memory_order_acquire);
  const auto wait = std::chrono::duration<double>(std::max(5 * period_s_, clear_loop_wait_s));
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
  while (Clock::now() < deadline) {
    if (reads_.load(std::memory_order_acquire) != before) return true;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return false;
}

void CanopenBusDevice::await_reset_by_loop() const {
  // The loop takes the request at its next read_axes() and publishes at write_axes().
  const auto limit = std::chrono::duration<double>(reset_timeout_s + 0.5);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(limit);
  std::optional<std::uint64_t> taken_before;
  for (;;) {
    if (!taken_before && !clear_requested_.load(std::memory_order_acquire))
      taken_before = publications_.load(std::memory_order_acquire);
    if (taken_before && publications_.load(std::memory_order_acquire) > *taken_before) {
      bool resetting = false, operational = true, faulted = false;
      for (std::size_t i = 0; i < nodes_.size(); ++i) {
        const ExchangeStatus st = exchange_status(i);
        resetting = resetting || st.resetting;
        operational = operational && st.operational;
        faulted = faulted || st.faulted;
      }
      if (!resetting && (operational || faulted)) return;
    }
    if (Clock::now() >= deadline || stop_.stop_requested()) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void CanopenBusDevice::disable() noexcept {
  enabled_.store(false, std::memory_order_release);
  try {
    disable_requested_.store(true, std::memory_order_release);
    if (loop_running()) {
      await_loop_handover(disable_requested_, reads_);
    } else {
      for (auto& node : nodes_) node->exchange->set_enabled(false);
      disable_requested_.store(false);
      run_periods([] { return false; }, 3);  // Disable Voltage goes out with the next SYNCs
    }
  } catch (...) {
  }
}

void CanopenBusDevice::close() noexcept {
  try {
    with_each_node_sdo([](Node& node, SdoClient& sdo, SocketLink& link) {
      if (!node.exchange) return;
      try {
        release_drive(sdo, link, node.config.node_id);
      } catch (...) {  // the next node's dead-man is undone all the same
      }
    });
  } catch (...) {
  }
  socket_.close();
  for (auto& node : nodes_) node->exchange.reset();
  configured_ = false;
  enabled_.store(false, std::memory_order_release);
}

// ---- RT ----------------------------------------------------------------------

IoResult CanopenBusDevice::read(Reading& out) noexcept {
  (void)out;
  return IoResult::error;
}

IoResult CanopenBusDevice::write(double force) noexcept {
  (void)force;
  return IoResult::error;
}

IoResult CanopenBusDevice::read_axes(std::span<Reading> out) noexcept {
  reads_.fetch_add(1, std::memory_order_release);
  if (out.size() != nodes_.size()) return IoResult::error;
  if (clear_requested_.exchange(false, std::memory_order_acq_rel)) {
    for (auto& node : nodes_) {
      node->exchange->set_enabled(true);
      if (node->exchange->faulted()) node->exchange->request_fault_reset();
    }
  }
  if (disable_requested_.exchange(false, std::memory_order_acq_rel))
    for (auto& node : nodes_) node->exchange->set_enabled(false);
  drain_socket();
  apply_torque_units();
  bool faulted = false, valid = true;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const CycleReading r = nodes_[i]->exchange->begin_period();
    faulted = faulted || nodes_[i]->exchange->faulted();
    valid = valid && r.valid;
    out[i].position = r.position;
    out[i].stale = !r.fresh;
  }
  if (faulted) return IoResult::fault;  // one node's fault zeroes every axis
  return valid ? IoResult::ok : IoResult::error;
}

void CanopenBusDevice::apply_torque_units() noexcept {
  TorqueUnitChange change;
  for (auto& node : nodes_) {
    while (node->unit_changes.try_pop(change)) {
      if (change.fault) node->exchange->on_torque_unit_changed(change.before_mnm, change.after_mnm);
      if (change.after_mnm != 0) node->exchange->set_force_per_permille(change.force_per_permille);
    }
  }
}

void CanopenBusDevice::drain_socket() noexcept {
  const std::size_t limit = static_cast<std::size_t>(max_frames_per_period) * nodes_.size();
  Frame f;
  for (std::size_t i = 0; i < limit; ++i) {
    const IoStatus s = socket_.receive(f);
    if (s == IoStatus::would_block) return;
    if (s == IoStatus::malformed) {
      // No node sent it that hapticd could tell: the bus is suspect for all.
      for (auto& node : nodes_) node->exchange->on_malformed_message(socket_.last_malformed());
      continue;
    }
    if (s != IoStatus::ok) {
      for (auto& node : nodes_) node->exchange->on_link_lost(socket_.last_errno(), s == IoStatus::closed);
      return;
    }
    // Each exchange takes its own node's COB-IDs; an error frame is the bus', every node's.
    for (auto& node : nodes_)
      if (node->exchange->on_frame(f) == FrameUse::sdo_response) node->sdo_answers.try_push(f);
  }
}

IoResult CanopenBusDevice::write_axes(std::span<const double> forces) noexcept {
  if (forces.size() != nodes_.size()) return IoResult::error;
  // A fault on one node: torque 0 to every node this period (the engine's
  // output is zero too; this does not rely on it).
  const bool zero_all = any(&CyclicExchange::faulted);
  bool heartbeat_due = false, link_ok = true;
  const auto send = [&](const Frame& frame, CyclicExchange& owner) {
    if (!link_ok) return;
    const IoStatus s = socket_.send(frame);
    if (s == IoStatus::would_block) {
      owner.on_frame_dropped();  // TX queue full: dropped, never waited for
    } else if (s != IoStatus::ok) {
      link_ok = false;
      for (auto& node : nodes_) node->exchange->on_link_lost(socket_.last_errno(), s == IoStatus::closed);
    }
  };
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    CyclicExchange& x = *nodes_[i]->exchange;
    std::array<Frame, 4> frames;
    const std::size_t n = x.end_period(zero_all ? 0.0 : forces[i], frames);
    for (std::size_t k = 0; k < n; ++k) {
      if (frames[k].id == cia301::cob::sync) continue;  // one SYNC for all, below
      if (frames[k].id == cia301::heartbeat_id(config_.master_node_id)) {
        heartbeat_due = true;  // one heartbeat for all
        continue;
      }
      send(frames[k], x);  // the node's NMT start (during its reset) and RPDO1
    }
  }
  CyclicExchange& first = *nodes_.front()->exchange;
  send(cia301::encode_sync(), first);
  if (heartbeat_due)
    send(cia301::encode_heartbeat(config_.master_node_id, cia301::NmtState::operational), first);
  publish_all();
  return any(&CyclicExchange::faulted) ? IoResult::fault : IoResult::ok;
}

void CanopenBusDevice::publish_all() noexcept {
  for (auto& node : nodes_) node->published.publish(*node->exchange);
  publications_.fetch_add(1, std::memory_order_release);
}

// ---- any non-RT thread -------------------------------------------------------

ExchangeStatus CanopenBusDevice::exchange_status(std::size_t axis) const {
  const Node& node = *nodes_.at(axis);
  if (!node.exchange) return {};
  return node.published.load(node.exchange->settings());
}

std::string CanopenBusDevice::fault_words() const {
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const ExchangeStatus st = exchange_status(i);
    if (st.faulted)
      return "axis " + std::to_string(i + 1) + " (node " + std::to_string(nodes_[i]->config.node_id) +
             "): " + st.fault_reason + "; every axis held at zero";
  }
  return "";
}

DeviceModel CanopenBusDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  const double unit = config_.motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  m.position_resolution = unit / config_.counts_per_unit;
  m.delay_periods =
      1;  // each node: the RPDO sent before SYNC n acts at SYNC n; the position is from SYNC n-1
  m.source = "config";
  m.effective_mass = INFINITY;
  for (const auto& node : nodes_) {
    m.axes.push_back({node->config.mass, node->config.damping});
    if (node->config.mass < m.effective_mass) {  // the lightest axis, as DeviceModel::axes says
      m.effective_mass = node->config.mass;
      m.viscous_damping = node->config.damping;
    }
  }
  m.description = "CiA 402 drives on one bus, nodes " + node_list_words(config_.node_ids) +
                  ", one per axis, cyclic synchronous torque";
  for (const auto& node : nodes_)
    for (const std::string& note : node->setup.notes)
      m.description += "; node " + std::to_string(node->config.node_id) + ": " + note;
  return m;
}

std::string CanopenBusDevice::identity() const {
  using world::text::format_hex;
  std::string out = "interface " + config_.interface;
  for (const auto& node : nodes_) {
    const DriveIdentity& id = node->setup.identity;
    out += ", node " + std::to_string(node->config.node_id) + " (vendor " + format_hex(id.vendor_id, 8) +
           ", product " + format_hex(id.product_code, 8) + ", serial " + format_hex(id.serial, 8) + ")";
  }
  return out;
}

DeviceHealth CanopenBusDevice::health() const {
  DeviceHealth h;
  if (!nodes_.front()->exchange) return h;
  h.fault_reason = fault_words();
  h.faulted = !h.fault_reason.empty();
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const ExchangeStatus st = exchange_status(i);
    const CyclicCounters& c = st.counters;
    const std::string p = "node" + std::to_string(nodes_[i]->config.node_id) + "_";
    for (const auto& [name, value] : {std::pair<const char*, std::uint64_t>{"periods", c.periods},
                                      {"tpdos", c.tpdos},
                                      {"late_tpdos", c.late_tpdos},
                                      {"short_tpdos", c.short_tpdos},
                                      {"emcys", c.emcys},
                                      {"error_frames", c.error_frames},
                                      {"drive_heartbeats", c.drive_heartbeats},
                                      {"tx_dropped", c.tx_dropped},
                                      {"malformed_frames", c.malformed_frames},
                                      {"malformed_messages", c.malformed_messages},
                                      {"statusword", st.statusword},
                                      {"controlword", st.controlword}})
      h.counters.push_back({p + name, value});
  }
  return h;
}

}  // namespace hapticd::drivers::canopen
