#include "drivers/canopen/device_settings.hpp"

#include <algorithm>
#include <cmath>

#include "drivers/canopen/301/cob_id.hpp"

namespace hapticd::drivers::canopen {

std::uint64_t periods_in(double seconds, double period_s) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(seconds / period_s - 1e-9)));
}

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

}  // namespace hapticd::drivers::canopen
