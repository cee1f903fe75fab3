#pragma once
/// \file
/// What the canopen hooks derive from the config for one drive (node): the
/// receive filters, the setup options, the per-period exchange's settings.
/// Shared by the one-drive hooks (canopen_device.hpp) and the hooks of
/// several drives on one bus (canopen_bus_device.hpp).

#include <cstdint>
#include <vector>

#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"

namespace hapticd::drivers::canopen {

inline constexpr double enable_timeout_s = 1.0;   ///< to Operation Enabled
inline constexpr double reset_timeout_s = 1.0;    ///< a fault reset back to Operation Enabled
inline constexpr int prime_attempts = 3;          ///< SYNCs sent for the first TPDO1
inline constexpr double clear_loop_wait_s = 0.1;  ///< how long a running loop may take to show up

/// Whole periods covering `seconds`, at least 1.
std::uint64_t periods_in(double seconds, double period_s);
/// The node's TPDOs, EMCY, SDO answers and heartbeat.
std::vector<CanFilter> receive_filters(const CanopenConfig& c, const CyclicMapping& m);
SetupOptions setup_options(const CanopenConfig& c, double period_s);
CyclicSettings cyclic_settings(const CanopenConfig& c, const SetupResult& setup, const Scaling& scaling,
                               double period_s);

}  // namespace hapticd::drivers::canopen
