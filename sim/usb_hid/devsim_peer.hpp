#pragma once
/// \file
/// `hapticd-devsim usb-hid`: the simulated board on an emulated USB bus, on
/// its own, for trying the usb-hid driver without hardware. It prints the
/// line that starts hapticd against it (LD_PRELOAD of libumockdev-preload and
/// the testbed's UMOCKDEV_DIR) and serves until SIGINT/SIGTERM.

#include "sim/devsim/peers.hpp"

namespace hapticd::drivers::usb_hid::sim {

devsim::SimulatedPeer usb_hid_peer();

}  // namespace hapticd::drivers::usb_hid::sim
